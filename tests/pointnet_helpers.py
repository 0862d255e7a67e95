"""PointNets with random weights and random batch-norm statistics, as after training, for the inference tests."""

from __future__ import annotations

import torch

from classify.pointnet import LinearBN, PointNet, PointNetConfig


def trained_like(cfg: PointNetConfig, seed: int) -> PointNet:
    """A PointNet (eval mode, batch norms not folded) whose weights, batch-norm statistics and affine terms are
    random, and whose T-Nets turn their input away from the identity, so that every part of the network matters."""
    torch.manual_seed(seed)
    net = PointNet(cfg)
    gen = torch.Generator().manual_seed(seed + 1)
    with torch.no_grad():
        for m in net.modules():
            if isinstance(m, LinearBN) and isinstance(m.bn, torch.nn.BatchNorm1d):
                c = m.bn.num_features
                assert m.bn.running_mean is not None and m.bn.running_var is not None
                m.bn.running_mean.copy_(torch.randn(c, generator=gen) * 0.1)
                m.bn.running_var.copy_(torch.rand(c, generator=gen) + 0.5)
                m.bn.weight.copy_(torch.rand(c, generator=gen) + 0.5)
                m.bn.bias.copy_(torch.randn(c, generator=gen) * 0.1)
        for tnet in (net.input_tnet, net.feature_tnet):
            if tnet is not None:  # a transform away from the identity, so the T-Nets matter
                tnet.out.weight.normal_(0.0, 0.01, generator=gen)
    return net.eval()
