"""A checkpoint's inference export: what inference needs from ``X.pt``, in ``X.npz`` beside it, read without PyTorch.

The file is a NumPy ``.npz`` (read with ``allow_pickle=False``: arrays only, no code) holding

* ``meta``: one JSON text (:class:`ExportMeta`): :data:`FORMAT`, the SHA-256 of the checkpoint file it was made
  from (``source_sha256``), the class names, points per cloud, the normalization (``scale_m`` m, ``z_ref``), the
  calibrated ``clutter_threshold`` (null: the default), the architecture switches (``input_transform``,
  ``feature_transform``), the number of ensemble members and the solid classes' top heights (``shadow_tops_m``,
  :mod:`classify.shadow_height`; absent: none) and the decision model (``decision``, :mod:`classify.decision`;
  absent: none);
* per linear layer of :class:`classify.pointnet.PointNet` (its ``state_dict`` name less ``.linear``/``.weight``,
  e.g. ``mlp2.2``, ``feature_tnet.fc.0``, ``classifier``): ``NAME.weight`` ``(members, out, in)`` and
  ``NAME.bias`` ``(members, out)`` float32, every batch norm folded into its layer
  (:meth:`classify.pointnet.PointNet.fused`).

:func:`classify.checkpoint.save_checkpoint` writes it with every checkpoint (training, ``auvlink eval
--calibrated-model``); ``auvlink train --export-inference X.pt`` writes it for an existing one. An export is used
only while its ``source_sha256`` is the checkpoint's (:func:`matching_export`): a checkpoint replaced or edited
after its export was made makes the export stale, and inference then runs the checkpoint with PyTorch.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Final, Literal

import numpy as np
import numpy.typing as npt
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from auvlink.atomic import atomic_path
from auvlink.file_digest import sha256_file
from classify.decision import DecisionMeta
from classify.errors import CheckpointError

FORMAT: Final = "auvlink.classify.pointnet-inference/1"
SUFFIX = ".npz"
#: most ensemble members and outputs an export may hold: those of classify.checkpoint_meta (MAX_MEMBERS + 1,
#: MAX_CLASSES), repeated here so that reading an export does not import PyTorch
MAX_MEMBERS = 49
MAX_CLASSES = 256
MAX_POINTS = 16_384  # classify.checkpoint_meta.MAX_POINTS

F32 = npt.NDArray[np.float32]


class ExportMeta(BaseModel):
    """The ``meta`` JSON of an export (see the module doc)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    format: Literal["auvlink.classify.pointnet-inference/1"]
    source_sha256: Annotated[str, Field(pattern=r"^[0-9a-f]{64}$")]
    class_names: Annotated[tuple[str, ...], Field(min_length=1, max_length=MAX_CLASSES)]
    n_points: Annotated[int, Field(ge=1, le=MAX_POINTS)]
    scale_m: Annotated[float, Field(ge=0.0)]
    z_ref: Literal["mean", "seabed"]
    clutter_threshold: Annotated[float, Field(ge=0.0, le=1.0)] | None
    input_transform: bool
    feature_transform: bool
    members: Annotated[int, Field(ge=1, le=MAX_MEMBERS)]
    #: m: the top height of each class of solid shape (classify.shadow_height); absent: none
    shadow_tops_m: dict[str, Annotated[float, Field(gt=0.0, le=100.0)]] | None = None
    #: the decision over the network's probabilities and the object's evidence (classify.decision); absent: none
    decision: DecisionMeta | None = None


@dataclass(frozen=True)
class InferenceExport:
    """An export read back: its metadata and the folded layers (name -> ``(weight (M, out, in), bias (M, out))``)."""

    meta: ExportMeta
    layers: Mapping[str, tuple[F32, F32]]


def export_path(checkpoint: Path | str) -> Path:
    """Where the export of ``checkpoint`` lives: ``X.npz`` beside ``X.pt``."""
    return Path(checkpoint).with_suffix(SUFFIX)


def write_export(path: Path, meta: ExportMeta, layers: Mapping[str, tuple[F32, F32]]) -> Path:
    """Write an export to ``path`` atomically (a temporary name renamed when whole); returns ``path``."""
    arrays: dict[str, Any] = {"meta": np.array(meta.model_dump_json())}
    for name, (w, b) in layers.items():
        arrays[f"{name}.weight"] = np.ascontiguousarray(w, dtype=np.float32)
        arrays[f"{name}.bias"] = np.ascontiguousarray(b, dtype=np.float32)
    check_layers(path, meta, _pairs(arrays))
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez(f, **arrays)
    return Path(path)


def _pairs(arrays: Mapping[str, npt.NDArray[np.generic]]) -> dict[str, tuple[F32, F32]]:
    names = sorted({k.rsplit(".", 1)[0] for k in arrays if k != "meta"})
    try:
        return {n: (np.asarray(arrays[f"{n}.weight"]), np.asarray(arrays[f"{n}.bias"])) for n in names}
    except KeyError as exc:
        raise CheckpointError(f"inference export: layer array {exc.args[0]!r} is missing") from exc


def check_layers(path: Path | str, meta: ExportMeta, layers: Mapping[str, tuple[F32, F32]]) -> None:
    """Every layer float32 ``(members, out, in)`` / ``(members, out)``, finite, and ``classifier`` with one output
    per class name; else :class:`CheckpointError` naming the layer."""
    for name, (w, b) in layers.items():
        if w.dtype != np.float32 or b.dtype != np.float32 or w.ndim != 3 or b.shape != w.shape[:2] \
                or w.shape[0] != meta.members:
            raise CheckpointError(f"{path}: inference export layer {name!r}: weight {w.dtype}{w.shape}, bias "
                                  f"{b.dtype}{b.shape} (allowed: float32 ({meta.members}, out, in) and "
                                  f"({meta.members}, out)); export the checkpoint again")
        if not (np.isfinite(w).all() and np.isfinite(b).all()):
            raise CheckpointError(f"{path}: inference export layer {name!r} holds NaN or inf")
    out = layers.get("classifier")
    if out is None or out[0].shape[1] != len(meta.class_names):
        raise CheckpointError(f"{path}: inference export: no classifier layer with {len(meta.class_names)} outputs")


def read_export(path: Path | str) -> InferenceExport:
    """The export at ``path``, checked (metadata fields, layer shapes, finite weights); :class:`CheckpointError`
    with one line naming what is wrong otherwise."""
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError) as exc:
        raise CheckpointError(f"{path}: not a readable inference export: {exc}") from exc
    if "meta" not in arrays:
        raise CheckpointError(f"{path}: inference export without its 'meta' record")
    try:
        meta = ExportMeta.model_validate(json.loads(str(arrays["meta"])))
    except (ValueError, ValidationError) as exc:
        first = exc.errors(include_url=False)[0] if isinstance(exc, ValidationError) else None
        where = ".".join(str(p) for p in first["loc"]) + ": " + first["msg"] if first else str(exc)
        raise CheckpointError(f"{path}: inference export metadata: {where}") from exc
    layers = _pairs(arrays)
    check_layers(path, meta, layers)
    return InferenceExport(meta, layers)


def matching_export(checkpoint: Path | str) -> tuple[InferenceExport | None, str]:
    """The export beside ``checkpoint`` when it was made from this very file (same SHA-256), else None; with the
    reason when None (no export, a stale one, an unreadable one)."""
    path = export_path(checkpoint)
    if not Path(checkpoint).is_file():
        return None, f"no checkpoint {checkpoint}"
    if not path.is_file():
        return None, f"no inference export {path}"
    try:
        export = read_export(path)
    except CheckpointError as exc:
        return None, str(exc)
    if export.meta.source_sha256 != sha256_file(checkpoint):
        return None, f"{path} was made from another {Path(checkpoint).name} (stale: its SHA-256 differs)"
    return export, ""
