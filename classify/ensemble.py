"""Several PointNets trained alike from different seeds, read as one: ``forward`` gives the log of their mean
class probabilities, so ``softmax`` of it is that mean and ``argmax`` its most probable class.

Why: trained from seeds 0-3 with the same settings, single models named 61-106 of 2067 objects of random surveys
wrongly (clouds recon made of 8 earlier evaluation seeds), mostly at the class boundaries the seabed's texture
blurs (hemisphere / box, reef_b / reef_a) and with the clutter threshold; their mean named 60 wrongly with seed 1's
clutter threshold, 75 with the threshold calibrated on the mean (11 of them objects called clutter; 64 between
object classes, against 61-73 for the single seeds). The spread between seeds is larger than the effect of most
training changes, so the shipped model averages them (``[train] members``,
:func:`classify.workflow.train_and_save`); on two fresh seeds of 40 surveys it raised P / R from 0.945 / 0.925 to
0.959 / 0.938 (benchmarks/RESULTS.md, session 19).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import torch
from torch import Tensor, nn

from classify.pointnet import PointNet, PointNetConfig


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

    def fused(self) -> Ensemble:
        """Every member with its batch norms folded (inference only)."""
        return Ensemble([cast(PointNet, m).fused() for m in self.members])
