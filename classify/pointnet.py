"""PointNet (Qi et al., CVPR 2017) for point-cloud classification, with a width multiplier.

Layout: input T-Net (3x3), shared MLP 64-64, feature T-Net (64x64, orthogonality regulariser
``||I - A A^T||_F^2``), shared MLP 64-128-1024, max pool, FC 512-256-k with dropout. Every channel
count is multiplied by ``width`` (``width=1`` is the paper's network).

Points are kept as ``(B, N, C)`` and each shared MLP layer is a ``Linear`` on the last axis (one
GEMM over ``B*N`` rows) with batch norm over the channel axis. :meth:`PointNet.fused` folds each
batch norm into its linear layer for inference, leaving ``linear -> relu`` chains only.
"""

from __future__ import annotations

import copy
import itertools
from dataclasses import asdict, dataclass
from typing import Any

import torch
from torch import Tensor, nn


@dataclass(frozen=True)
class PointNetConfig:
    """Architecture of a :class:`PointNet` (stored in checkpoints)."""

    num_classes: int
    width: float = 1.0
    input_transform: bool = True
    feature_transform: bool = True
    dropout: float = 0.3

    def ch(self, n: int) -> int:
        """``n`` channels scaled by the width multiplier (at least 4)."""
        return max(4, round(n * self.width))

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PointNetConfig:
        return cls(**{k: d[k] for k in cls.__dataclass_fields__ if k in d})


class LinearBN(nn.Module):
    """``Linear -> BatchNorm (over channels) -> ReLU`` on ``(..., C)``; foldable for inference."""

    def __init__(self, c_in: int, c_out: int, relu: bool = True) -> None:
        super().__init__()
        self.linear = nn.Linear(c_in, c_out, bias=True)
        self.bn: nn.Module = nn.BatchNorm1d(c_out)
        self.relu = relu

    def forward(self, x: Tensor) -> Tensor:
        y = self.linear(x)
        if not isinstance(self.bn, nn.Identity):
            shape = y.shape
            y = self.bn(y.reshape(-1, shape[-1])).reshape(shape)
        return torch.relu(y) if self.relu else y

    def fuse_(self) -> None:
        """Fold the batch norm's running statistics into the linear layer (in place)."""
        if not isinstance(self.bn, nn.BatchNorm1d):
            return
        bn = self.bn
        assert bn.running_var is not None and bn.running_mean is not None
        scale = bn.weight / torch.sqrt(bn.running_var + bn.eps)
        with torch.no_grad():
            self.linear.weight.mul_(scale[:, None])
            self.linear.bias.copy_((self.linear.bias - bn.running_mean) * scale + bn.bias)
        self.bn = nn.Identity()


def _mlp(dims: list[int]) -> nn.Sequential:
    return nn.Sequential(*[LinearBN(a, b) for a, b in itertools.pairwise(dims)])


class TNet(nn.Module):
    """Predicts a ``k x k`` transform from a ``(B, N, k)`` cloud; starts at the identity."""

    def __init__(self, k: int, cfg: PointNetConfig) -> None:
        super().__init__()
        self.k = k
        self.point_mlp = _mlp([k, cfg.ch(64), cfg.ch(128), cfg.ch(1024)])
        self.fc = _mlp([cfg.ch(1024), cfg.ch(512), cfg.ch(256)])
        self.out = nn.Linear(cfg.ch(256), k * k)
        nn.init.zeros_(self.out.weight)
        with torch.no_grad():
            self.out.bias.copy_(torch.eye(k).flatten())

    def forward(self, x: Tensor) -> Tensor:
        g = self.point_mlp(x).amax(dim=1)
        return self.out(self.fc(g)).view(-1, self.k, self.k)


class PointNet(nn.Module):
    """PointNet classifier: ``forward(points (B, N, 3)) -> (logits (B, k), feature transform | None)``."""

    def __init__(self, cfg: PointNetConfig) -> None:
        super().__init__()
        self.cfg = cfg
        c64, c128, c1024 = cfg.ch(64), cfg.ch(128), cfg.ch(1024)
        self.input_tnet = TNet(3, cfg) if cfg.input_transform else None
        self.mlp1 = _mlp([3, c64, c64])
        self.feature_tnet = TNet(c64, cfg) if cfg.feature_transform else None
        self.mlp2 = _mlp([c64, c64, c128, c1024])
        self.head = _mlp([c1024, cfg.ch(512), cfg.ch(256)])
        self.dropout = nn.Dropout(cfg.dropout)
        self.classifier = nn.Linear(cfg.ch(256), cfg.num_classes)

    def forward(self, x: Tensor) -> tuple[Tensor, Tensor | None]:
        if self.input_tnet is not None:
            x = torch.bmm(x, self.input_tnet(x))
        x = self.mlp1(x)
        trans = None
        if self.feature_tnet is not None:
            trans = self.feature_tnet(x)
            x = torch.bmm(x, trans)
        g = self.mlp2(x).amax(dim=1)
        g = self.head[0](g)
        g = self.dropout(self.head[1](g))
        return self.classifier(g), trans

    def fused(self) -> PointNet:
        """An eval-mode copy with every batch norm folded into its linear layer (inference only)."""
        model = copy.deepcopy(self).eval()
        for m in model.modules():
            if isinstance(m, LinearBN):
                m.fuse_()
        return model


def orthogonality_loss(trans: Tensor) -> Tensor:
    """Mean over the batch of ``||I - A A^T||_F^2`` (PointNet's feature-transform regulariser)."""
    k = trans.shape[-1]
    eye = torch.eye(k, device=trans.device, dtype=trans.dtype)
    diff = eye - torch.bmm(trans, trans.transpose(1, 2))
    return (diff**2).sum(dim=(1, 2)).mean()


def default_device() -> torch.device:
    """CUDA when present, else the CPU."""
    return torch.device("cuda" if torch.cuda.is_available() else "cpu")


def count_parameters(model: nn.Module) -> int:
    return sum(p.numel() for p in model.parameters())
