"""Several PointNets trained alike from different seeds, read as one: ``forward`` gives the log of their mean
class probabilities, so ``softmax`` of it is that mean and ``argmax`` its most probable class.

Models trained with the same settings from different seeds disagree most at the class boundaries that the
seabed's texture blurs (hemisphere / box, reef_b / reef_a) and on the clutter threshold; their mean is steadier
than any one of them. ``[train] members`` sets how many a checkpoint holds (the first plus ``members - 1``
further seeds, :func:`classify.training.workflow.train_and_save`); :mod:`classify.checkpoint` saves them in one file.

:class:`StackedPointNets` runs every member at once for inference: each layer's weights stacked over the
members ``(M, in, out)``, so one batched matrix product per layer serves all members, clouds and views
(``M`` forward passes become one, with ``M`` times the rows per product).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import torch
from torch import Tensor, nn

from classify.pointnet import LinearBN, PointNet, PointNetConfig, TNet


class Ensemble(nn.Module):
    """``forward(points (B, N, 3)) -> (log mean probability (B, k), None)`` over its members."""

    def __init__(self, members: Sequence[PointNet]) -> None:
        super().__init__()
        if not members:
            raise ValueError("an ensemble needs at least one member")
        self.members = nn.ModuleList(members)
        self.cfg: PointNetConfig = members[0].cfg

    def forward(self, x: Tensor) -> tuple[Tensor, None]:
        p = torch.stack([torch.softmax(m(x)[0].float(), dim=1) for m in self.members]).mean(dim=0)
        return torch.log(p.clamp_min(1e-12)), None

    @property
    def networks(self) -> list[PointNet]:
        """The members, in order."""
        return [cast(PointNet, m) for m in self.members]

    def fused(self) -> Ensemble:
        """Every member with its batch norms folded (inference only)."""
        return Ensemble([cast(PointNet, m).fused() for m in self.members])


class _Stack:
    """One layer of every member: weights ``(M, in, out)`` (a transposed view of the ``(M, out, in)`` stack, so each
    member's product runs the kernel ``nn.Linear`` runs, to the bit) and biases ``(M, 1, out)``."""

    def __init__(self, layers: Sequence[nn.Linear]) -> None:
        self.w = torch.stack([la.weight.detach() for la in layers]).transpose(1, 2)
        self.b = torch.stack([la.bias.detach()[None] for la in layers])

    def linear(self, x: Tensor) -> Tensor:
        """``x @ w + b``: ``x`` ``(M, R, in)`` or ``(1, R, in)`` (shared by every member) -> ``(M, R, out)``."""
        return torch.baddbmm(self.b, x.expand(self.w.shape[0], -1, -1), self.w)

    def __call__(self, x: Tensor, relu: bool = True) -> Tensor:
        y = self.linear(x)
        return torch.relu(y) if relu else y

    def pooled(self, x: Tensor, clouds: int) -> Tensor:
        """``relu(x @ w + b)`` max-pooled over each cloud's points: ``x`` ``(M, clouds * n, in)`` ->
        ``(M, clouds, out)``. The ReLU comes after the maximum (it is monotone: the same numbers, and the big
        per-point tensor is not passed over again)."""
        y = self.linear(x)
        return torch.relu(y.reshape(y.shape[0], clouds, -1, y.shape[-1]).amax(dim=2))


def _linears(seq: nn.Module) -> list[nn.Linear]:
    return [cast(LinearBN, m).linear for m in cast(nn.Sequential, seq)]


class _StackedTNet:
    """Every member's T-Net (:class:`classify.pointnet.TNet`) at once."""

    def __init__(self, tnets: Sequence[TNet]) -> None:
        self.k = tnets[0].k
        self.point = [_Stack(ls) for ls in zip(*[_linears(t.point_mlp) for t in tnets], strict=True)]
        self.fc = [_Stack(ls) for ls in zip(*[_linears(t.fc) for t in tnets], strict=True)]
        self.out = _Stack([t.out for t in tnets])

    def __call__(self, x: Tensor, clouds: int) -> Tensor:
        """``x`` ``(M or 1, clouds * n, k)`` -> transforms ``(M, clouds, k, k)``."""
        for layer in self.point[:-1]:
            x = layer(x)
        g = self.point[-1].pooled(x, clouds)
        for layer in self.fc:
            g = layer(g)
        t = self.out(g, relu=False)
        return t.reshape(t.shape[0], clouds, self.k, self.k)


class StackedPointNets:
    """The members of an ensemble (fused, eval mode, same :class:`PointNetConfig`) as one network:
    ``__call__(points (B, N, 3)) -> class probability (B, k)`` (float32): with several members the softmax of
    :class:`Ensemble`'s output (the log of the members' mean probability), with one the softmax of its logits; the
    numbers the members run one by one give, to the bit (each layer's product is the same kernel call per member).
    """

    def __init__(self, members: Sequence[PointNet]) -> None:
        if not members:
            raise ValueError("a stack needs at least one member")
        if any(isinstance(m, LinearBN) and not isinstance(m.bn, nn.Identity) for p in members for m in p.modules()):
            raise ValueError("stack fused members (PointNet.fused): batch norms must be folded first")
        self.cfg = members[0].cfg
        self.input_tnet = _StackedTNet([cast(TNet, m.input_tnet) for m in members]) if self.cfg.input_transform \
            else None
        self.mlp1 = [_Stack(ls) for ls in zip(*[_linears(m.mlp1) for m in members], strict=True)]
        self.feature_tnet = _StackedTNet([cast(TNet, m.feature_tnet) for m in members]) \
            if self.cfg.feature_transform else None
        self.mlp2 = [_Stack(ls) for ls in zip(*[_linears(m.mlp2) for m in members], strict=True)]
        self.head = [_Stack(ls) for ls in zip(*[_linears(m.head) for m in members], strict=True)]
        self.classifier = _Stack([m.classifier for m in members])

    def __call__(self, points: Tensor) -> Tensor:
        b, n, _ = points.shape
        x = points.reshape(1, b * n, 3)  # shared by every member until the first per-member transform
        if self.input_tnet is not None:
            x = _transform(x, self.input_tnet(x, b))
        for layer in self.mlp1:
            x = layer(x)
        if self.feature_tnet is not None:
            x = _transform(x, self.feature_tnet(x, b))
        for layer in self.mlp2[:-1]:
            x = layer(x)
        g = self.mlp2[-1].pooled(x, b)
        for layer in self.head:
            g = layer(g)
        logits = self.classifier(g, relu=False).float()
        if logits.shape[0] == 1:
            return torch.softmax(logits[0], dim=1)
        mean = torch.softmax(logits, dim=2).mean(dim=0)
        return torch.softmax(torch.log(mean.clamp_min(1e-12)), dim=1)


def _transform(x: Tensor, trans: Tensor) -> Tensor:
    """Each cloud's points ``x`` ``(M or 1, B * n, k)`` times its transform ``trans`` ``(M, B, k, k)``."""
    m, b, k, _ = trans.shape
    return torch.matmul(x.reshape(x.shape[0], b, -1, k), trans).reshape(m, -1, k)
