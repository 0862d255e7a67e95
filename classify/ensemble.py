"""Several PointNets trained alike from different seeds, read as one: ``forward`` gives the log of their mean
class probabilities, so ``softmax`` of it is that mean and ``argmax`` its most probable class.

Models trained with the same settings from different seeds disagree most at the class boundaries that the
seabed's texture blurs (hemisphere / box, reef_b / reef_a) and on the clutter threshold; their mean is steadier
than any one of them. ``[train] members`` sets how many a checkpoint holds (the first plus ``members - 1``
further seeds, :func:`classify.training.workflow.train_and_save`); :mod:`classify.checkpoint` saves them in one file.
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
