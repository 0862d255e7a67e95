"""Classifying reconstructed clouds with a trained checkpoint.

``Classifier.load(path).classify(points)`` takes one object's points ``(n, 3)`` in the world frame
(NED, metres), subsamples them to the model's point count when there are more (a fixed-seed draw:
same cloud, same answer), centres and scales them into the unit sphere as in training, and returns
``(class_name, score)`` with the softmax probability as the score (a checkpoint of several models trained from other
seeds, ``[train] members``: the mean of their probabilities). A model trained on
seabed-referenced clouds (synthesis ``z_ref = "seabed"``) also takes the depth of the seabed under the
object (``seabed_depth``, m, NED; recon gives it with each object: ``recon.cluster.DetectedObject.seabed_depth``):
the object's height above the seabed is then a feature. Without it, the cloud's deepest point stands
in for the seabed (objects then look shorter than they are: pass the depth). Batch-norm layers are folded
into their linear layers once at load time; inference runs under ``torch.inference_mode``.

PyTorch is one of two ways to run the network: :func:`classify.numpy_infer.load_classifier` (what replay, live and
batch runs call) uses the checkpoint's inference export (``X.npz`` beside ``X.pt``, NumPy only) when it matches the
checkpoint, and this module's :class:`Classifier` otherwise. Both share
:class:`classify.cloud_classifier.CloudClassifier` (the checks, normalization, batching and clutter rule below).

Test-time yaw views (``yaw_views``, default :data:`YAW_VIEWS`): the network was trained with a random yaw about
the down axis (an object's heading and the pass direction are unknown), so each cloud is also shown turned by
``360 / yaw_views`` degree steps about its vertical axis and the probabilities of the views are averaged.

A model trained with the class ``clutter`` (:data:`classify.labels.CLUTTER`: not an object, what recon makes of a
rough seabed) names a cloud ``clutter`` when that probability reaches the checkpoint's calibrated
``clutter_threshold`` (:meth:`Classifier.decide`); otherwise the most probable object class. A checkpoint
without that class (8 outputs) never says ``clutter``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
import torch

from classify.checkpoint import Checkpoint, load_checkpoint
from classify.cloud_classifier import (
    DEFAULT_CLUTTER_THRESHOLD,
    DEFAULT_MODEL,
    YAW_VIEWS,
    CloudClassifier,
    check_cloud,
    pad_by_repeating,
)
from classify.ensemble import Ensemble, StackedPointNets
from classify.pointnet import PointNet, default_device

__all__ = ["DEFAULT_CLUTTER_THRESHOLD", "DEFAULT_MODEL", "YAW_VIEWS", "Classifier", "check_cloud", "pad_by_repeating",
           "turned_views"]


def turned_views(x: torch.Tensor, views: int) -> torch.Tensor:
    """Normalized clouds ``(B, n, 3)`` (centred horizontally) as ``(B * views, n, 3)``: each turned about the
    vertical axis by ``0, 360 / views, ...`` degrees, the views of one cloud consecutive."""
    if views <= 1:
        return x
    a = torch.arange(views, dtype=x.dtype, device=x.device) * (2.0 * np.pi / views)
    c, s = torch.cos(a), torch.sin(a)
    rot = torch.zeros(views, 3, 3, dtype=x.dtype, device=x.device)
    rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1], rot[:, 2, 2] = c, -s, s, c, 1.0
    # (B, 1, n, 3) @ (1, V, 3, 3)^T -> (B, V, n, 3)
    return (x[:, None] @ rot.transpose(1, 2)[None]).reshape(-1, x.shape[1], 3)


class Classifier(CloudClassifier):
    """A trained PointNet ready for inference with PyTorch (CPU by default, CUDA when present)."""

    backend = "torch"

    def __init__(self, ckpt: Checkpoint, device: torch.device | None = None, yaw_views: int = YAW_VIEWS) -> None:
        super().__init__(ckpt.class_names, ckpt.n_points, float(ckpt.synthesis.get("scale_m", 0.0) or 0.0),
                         str(ckpt.synthesis.get("z_ref", "mean") or "mean"),
                         ckpt.calibration.get("clutter_threshold"), yaw_views,  # a probability (checked on load)
                         ckpt.calibration.get("shadow_tops_m"), ckpt.calibration.get("decision"))
        self.device = device or default_device()
        self.checkpoint = ckpt
        #: the network (an :class:`classify.ensemble.Ensemble` when the checkpoint holds several seeds' models)
        self.model: PointNet | Ensemble = (Ensemble([ckpt.model, *ckpt.members]) if ckpt.members else ckpt.model
                                           ).to(self.device).fused().eval()
        #: every member of :attr:`model` in one network (what :meth:`batch_probabilities` runs)
        self.stacked = StackedPointNets(self.model.networks if isinstance(self.model, Ensemble)
                                        else [self.model])

    @classmethod
    def load(cls, path: Path | str | None = None, device: torch.device | None = None,
             yaw_views: int = YAW_VIEWS) -> Classifier:
        """Load a checkpoint (the shipped default model when ``path`` is None); ``yaw_views``: see the module doc."""
        device = device or default_device()
        return cls(load_checkpoint(Path(path) if path is not None else DEFAULT_MODEL, device), device, yaw_views)

    def batch_probabilities(self, clouds: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
        """Class probabilities ``(B, k)`` of normalized clouds ``(B, n, 3)``: one pass of :attr:`stacked` over
        every member, view and cloud, the views' probabilities averaged."""
        with torch.inference_mode():
            x = turned_views(torch.from_numpy(clouds).to(self.device), self.yaw_views)
            prob = self.stacked(x)
            return prob.reshape(len(clouds), self.yaw_views, -1).mean(dim=1).cpu().numpy()
