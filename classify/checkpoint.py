"""Checkpoints: one ``torch.save`` dict of the weights and plain metadata, loaded with
``weights_only=True`` (no pickled code).

Keys: ``format``, ``state_dict``, ``model_config`` (:class:`PointNetConfig`), ``class_names``,
``n_points`` (points per cloud fed to the network), ``synthesis`` (:class:`SynthesisSettings`),
``train`` (:class:`TrainConfig`), ``metrics`` (any JSON-like dict), ``calibration`` (settings measured after
training that inference applies: ``clutter_threshold``, the probability of ``clutter`` from which a cloud is
called clutter; a checkpoint without it never calls a cloud clutter. A threshold set from survey replays
(``auvlink eval --surveys N --calibrated-model``, ``auvlink train --calibrate-surveys N``) keeps the one it replaced
as ``clutter_threshold_before`` and says where it came from in ``clutter_threshold_source``; the shipped model
also holds its held-out calibration as ``clutter_threshold_heldout``),
``members`` (optional: the state dicts of
further models of the same config, trained from other seeds; inference averages their probabilities with the
first's, :class:`classify.ensemble.Ensemble`).
Every key is checked on load before a network is built (:mod:`classify.checkpoint_meta`: names, sizes,
thresholds in range, no NaN anywhere).

Every saved checkpoint ``X.pt`` gets its inference export ``X.npz`` beside it (:func:`write_inference_export`,
:mod:`classify.inference_export`: the folded weights and what inference reads, for a run without PyTorch);
:func:`export_checkpoint` writes it for an existing checkpoint.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch

from auvlink.atomic import atomic_path
from classify.checkpoint_meta import FORMAT, CheckpointMeta, check_checkpoint, network_config
from classify.errors import CheckpointError
from classify.inference_export import FORMAT as EXPORT_FORMAT
from classify.inference_export import ExportMeta, export_path, sha256_file, write_export
from classify.pointnet import PointNet


@dataclass
class Checkpoint:
    model: PointNet
    class_names: tuple[str, ...]
    n_points: int
    synthesis: dict[str, Any] = field(default_factory=dict)
    train: dict[str, Any] = field(default_factory=dict)
    metrics: dict[str, Any] = field(default_factory=dict)
    calibration: dict[str, Any] = field(default_factory=dict)
    members: list[PointNet] = field(default_factory=list)  # further models (other seeds), averaged with ``model``


def _plain(x: Any) -> Any:
    """JSON-like copy (tuples to lists, numpy scalars to Python) that ``weights_only`` loads."""
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_plain(v) for v in x]
    if hasattr(x, "item") and callable(x.item):
        return x.item()
    return x


def save_checkpoint(path: Path, model: PointNet, class_names: Sequence[str], n_points: int,
                    synthesis: dict[str, Any] | None = None, train: dict[str, Any] | None = None,
                    metrics: dict[str, Any] | None = None, calibration: dict[str, Any] | None = None,
                    members: Sequence[PointNet] = ()) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    for m in members:
        if m.cfg != model.cfg:
            raise CheckpointError(f"an ensemble member's config {m.cfg} differs from the first's {model.cfg}")
    doc = {"format": FORMAT, "state_dict": _state(model), "model_config": _plain(model.cfg.to_dict()),
           "class_names": list(class_names), "n_points": int(n_points),
           "synthesis": _plain(synthesis or {}), "train": _plain(train or {}),
           "metrics": _plain(metrics or {}), "calibration": _plain(calibration or {})}
    if members:
        doc["members"] = [_state(m) for m in members]
    check_checkpoint(doc, path)  # what load_checkpoint would refuse is never written
    with atomic_path(path) as tmp:  # renamed when whole: an interrupted save never leaves half a checkpoint
        torch.save(doc, tmp)
    write_inference_export(path, [model, *members], class_names, n_points, synthesis or {}, calibration or {})
    return path


def save_recalibrated(ck: Checkpoint, path: Path, calibration: dict[str, Any]) -> Path:
    """``ck`` (networks, names and metadata as loaded) saved at ``path`` with its ``calibration`` replaced, with
    its inference export (:func:`save_checkpoint`)."""
    return save_checkpoint(path, ck.model, ck.class_names, ck.n_points, ck.synthesis, ck.train, ck.metrics,
                           calibration, ck.members)


def write_inference_export(path: Path, models: Sequence[PointNet], class_names: Sequence[str], n_points: int,
                           synthesis: dict[str, Any], calibration: dict[str, Any]) -> Path:
    """Write the inference export of the checkpoint saved at ``path`` (its networks ``models``, first then the
    further members, and its metadata) to ``X.npz`` beside it; returns that path."""
    folded = [m.fused().cpu() for m in models]
    layers: dict[str, tuple[Any, Any]] = {}
    for key in folded[0].state_dict():
        if key.endswith(".weight"):
            name = key.removesuffix(".weight").removesuffix(".linear")
            bias = key.removesuffix("weight") + "bias"
            layers[name] = (torch.stack([m.state_dict()[key] for m in folded]).numpy(),
                            torch.stack([m.state_dict()[bias] for m in folded]).numpy())
    cfg = models[0].cfg
    threshold = calibration.get("clutter_threshold")
    meta = ExportMeta.model_validate({
        "format": EXPORT_FORMAT, "source_sha256": sha256_file(path), "class_names": tuple(class_names),
        "n_points": int(n_points), "scale_m": float(synthesis.get("scale_m", 0.0) or 0.0),
        "z_ref": str(synthesis.get("z_ref") or "mean"),
        "clutter_threshold": None if threshold is None else float(threshold),
        "input_transform": cfg.input_transform, "feature_transform": cfg.feature_transform, "members": len(folded),
        "shadow_tops_m": calibration.get("shadow_tops_m"), "decision": calibration.get("decision")})
    return write_export(export_path(path), meta, layers)


def export_checkpoint(path: Path) -> Path:
    """Write the inference export of the existing checkpoint at ``path`` (checked whole first,
    :func:`load_checkpoint`); returns the export's path."""
    ck = load_checkpoint(path)
    return write_inference_export(Path(path), [ck.model, *ck.members], ck.class_names, ck.n_points, ck.synthesis,
                                  ck.calibration)


def _state(model: PointNet) -> dict[str, torch.Tensor]:
    return {k: v.detach().cpu().clone() for k, v in model.state_dict().items()}


def _one_line(exc: BaseException, limit: int = 300) -> str:
    text = " ".join(str(exc).split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


def read_checkpoint(path: Path, device: torch.device | str = "cpu") -> tuple[dict[str, Any], CheckpointMeta]:
    """The checkpoint dict at ``path``, read with ``weights_only=True`` (no pickled code runs) and checked whole
    (:func:`classify.checkpoint_meta.check_checkpoint`: every field, the weights' values); builds no network.
    :class:`CheckpointError` naming the field otherwise."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"no checkpoint at {path}")
    try:
        d = torch.load(path, map_location=device, weights_only=True)
    except Exception as exc:  # torch raises many types for a bad file
        raise CheckpointError(f"{path}: not a readable checkpoint: {_one_line(exc)}") from exc
    return d, check_checkpoint(d, path)


def load_checkpoint(path: Path, device: torch.device | str = "cpu") -> Checkpoint:
    """The checkpoint at ``path`` (:func:`read_checkpoint`), its networks built once it is checked."""
    d, meta = read_checkpoint(path, device)
    cfg = network_config(meta)
    models = []
    try:
        for state in [meta.state_dict, *meta.members]:
            model = PointNet(cfg)
            model.load_state_dict(state)
            models.append(model.to(device).eval())
    except (KeyError, RuntimeError, TypeError) as exc:
        raise CheckpointError(f"{path}: weights do not match the stored model config: {_one_line(exc)}") from exc
    return Checkpoint(models[0], tuple(meta.class_names), meta.n_points, d.get("synthesis", {}),
                      d.get("train", {}), d.get("metrics", {}), d.get("calibration", {}), models[1:])
