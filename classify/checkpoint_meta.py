"""What a checkpoint may hold, checked before any network is built: :func:`check_checkpoint`.

A checkpoint is data (a file from anywhere): :class:`CheckpointMeta` (pydantic) describes every key of the
dict :func:`classify.checkpoint.save_checkpoint` writes, and :func:`check_checkpoint` raises one
:class:`~classify.errors.CheckpointError` line naming the first bad field and what is allowed there:

* ``class_names``: 1 to :data:`MAX_CLASSES` plain identifiers (:data:`CLASS_NAME`: a lowercase letter, then
  lowercase letters, digits or ``_``; at most :data:`MAX_NAME_LENGTH` characters), unique, exactly as many as
  the network's outputs (``model_config.num_classes``): they name output files and appear in reports;
* ``model_config``: ``width`` in (0, :data:`MAX_WIDTH`], ``num_classes`` in [1, :data:`MAX_CLASSES`],
  ``dropout`` in [0, 1), the transforms true or false; ``n_points`` in [1, :data:`MAX_POINTS`];
* ``calibration``: every ``clutter_threshold*`` a probability in [0, 1]; shares and rates in [0, 1], counts
  >= 0; ``synthesis``: ``scale_m`` in [0, :data:`MAX_SCALE_M`] (0: clouds scaled into the unit sphere),
  ``z_ref`` ``mean`` or ``seabed``; ``members``: at most :data:`MAX_MEMBERS` further models;
* everywhere (``synthesis``, ``train``, ``metrics``, ``calibration`` included): JSON-like values only (text,
  numbers, true/false, null, lists, tables with text keys; at most :data:`MAX_DEPTH` levels), every number
  finite (no NaN, no inf);
* the weights: tables of tensors, every value finite (their names and shapes are checked as they are loaded
  into the network, whose size the bounds above keep small).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

import torch
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationError

from auvlink.validation import Boolean, Integer, Number
from classify.decision import DecisionMeta
from classify.errors import CheckpointError
from classify.pointnet import PointNetConfig

FORMAT = "auvlink.classify.pointnet/1"
#: largest channel multiplier: 16 x the shipped model's 0.25 (classify/data/train_default.toml; 1 is the paper's
#: network); a width-4 PointNet has 106 M parameters (403 MiB), width 8 already 691 M (2.6 GiB)
MAX_WIDTH = 4.0
#: most points per cloud fed to the network: 64 x the shipped model's 256 (train_default.toml ``[train] n_points``)
MAX_POINTS = 16_384
#: most outputs: the catalogue's 8 object classes and ``clutter``, x 28
MAX_CLASSES = 256
#: most further models averaged with the first: 16 x the shipped model's 3 (``[train] members = 4``)
MAX_MEMBERS = 48
#: largest normalization scale (m): the shipped 1.5 m x 66; the catalogue's largest object is under 5 m
MAX_SCALE_M = 100.0
#: deepest nesting of a metadata table (the shipped checkpoint's is 4: metrics.history[i].key)
MAX_DEPTH = 32
MAX_NAME_LENGTH = 64
#: what a class name may be (it names files: ``objects/object_001_<class>.ply``)
CLASS_NAME = re.compile(r"[a-z][a-z0-9_]*")
CLASS_NAME_RULE = (f"a plain identifier: a lowercase letter, then lowercase letters, digits or _, at most "
                   f"{MAX_NAME_LENGTH} characters")

CONFIG = ConfigDict(extra="forbid", allow_inf_nan=False)
OPEN = ConfigDict(extra="allow", allow_inf_nan=False)


def _class_name(name: str) -> str:
    if len(name) > MAX_NAME_LENGTH or not CLASS_NAME.fullmatch(name):
        raise ValueError("not a plain identifier")
    return name


Probability = Annotated[Number, Field(ge=0.0, le=1.0)]
ClassName = Annotated[str, Field(strict=True), AfterValidator(_class_name)]


class NetworkMeta(BaseModel):
    """``model_config``: the fields of :class:`classify.pointnet.PointNetConfig`."""

    model_config = CONFIG
    num_classes: Annotated[Integer, Field(ge=1, le=MAX_CLASSES)]
    width: Annotated[Number, Field(gt=0.0, le=MAX_WIDTH)] = 1.0
    input_transform: Boolean = True
    feature_transform: Boolean = True
    dropout: Annotated[Number, Field(ge=0.0, lt=1.0)] = 0.3


class SynthesisMeta(BaseModel):
    """``synthesis``: the fields inference reads (the others: JSON-like and finite)."""

    model_config = OPEN
    scale_m: Annotated[Number, Field(ge=0.0, le=MAX_SCALE_M)] | None = None
    z_ref: Literal["mean", "seabed"] | None = None


class CalibrationMeta(BaseModel):
    """``calibration``: the clutter threshold inference applies, and what calibrated it."""

    model_config = OPEN
    clutter_threshold: Probability | None = None
    clutter_threshold_before: Probability | None = None
    clutter_threshold_heldout: Probability | None = None
    clutter_share: Probability | None = None
    objects_called_clutter: Probability | None = None
    clutter_recall: Probability | None = None
    n_objects: Annotated[Integer, Field(ge=0)] | None = None
    n_clutter: Annotated[Integer, Field(ge=0)] | None = None
    clutter_threshold_source: str | None = None
    #: m: the top height of each class of solid shape (classify.shadow_height), and where they came from
    shadow_tops_m: dict[ClassName, Annotated[Number, Field(gt=0.0, le=MAX_SCALE_M)]] | None = None
    shadow_tops_source: str | None = None
    #: the decision over the network's probabilities and each object's evidence (classify.decision)
    decision: DecisionMeta | None = None


class CheckpointMeta(BaseModel):
    """The whole checkpoint dict (the weights only as tables; :func:`check_weights` checks them)."""

    model_config = CONFIG
    format: Literal["auvlink.classify.pointnet/1"]  # FORMAT
    network: NetworkMeta = Field(alias="model_config")
    class_names: Annotated[tuple[ClassName, ...], Field(min_length=1, max_length=MAX_CLASSES)]
    n_points: Annotated[Integer, Field(ge=1, le=MAX_POINTS)]
    synthesis: SynthesisMeta = Field(default_factory=SynthesisMeta)
    train: dict[str, Any] = Field(default_factory=dict)
    metrics: dict[str, Any] = Field(default_factory=dict)
    calibration: CalibrationMeta = Field(default_factory=CalibrationMeta)
    state_dict: dict[str, Any]
    members: Annotated[list[dict[str, Any]], Field(max_length=MAX_MEMBERS)] = Field(default_factory=list)


#: what each field allows, for the error line (keys: the dotted field without list indices)
ALLOWED = {
    "format": f"{FORMAT!r}",
    "model_config": "a table of num_classes, width, input_transform, feature_transform, dropout",
    "model_config.num_classes": f"an integer in [1, {MAX_CLASSES}], as many as class_names",
    "model_config.width": f"a number in (0, {MAX_WIDTH:g}]",
    "model_config.dropout": "a number in [0, 1)",
    "class_names": f"1 to {MAX_CLASSES} unique names, each {CLASS_NAME_RULE}",
    "n_points": f"an integer in [1, {MAX_POINTS}]",
    "synthesis.scale_m": f"a number in [0, {MAX_SCALE_M:g}] m (0: unit sphere)",
    "synthesis.z_ref": "'mean' or 'seabed'",
    "calibration.n_objects": "an integer >= 0",
    "calibration.n_clutter": "an integer >= 0",
    "calibration.clutter_threshold_source": "text",
    "members": f"a list of at most {MAX_MEMBERS} weight tables",
    "state_dict": "a table of tensors",
}


def _allowed(key: str, default: str = "see classify/checkpoint_meta.py") -> str:
    bare = re.sub(r"\[\d+\]", "", key)
    if bare in ALLOWED:
        return ALLOWED[bare]
    if bare.endswith("_transform"):
        return "true or false"
    if bare in {f"calibration.{k}" for k in CalibrationMeta.model_fields}:
        return "text" if bare.endswith("_source") else "a number in [0, 1]"
    return default


def _shown(value: Any) -> str:
    text = ascii(value) if not isinstance(value, Mapping | list | tuple) else type(value).__name__
    return text if len(text) <= 80 else text[:77] + "..."


def field_error(path: Path | str, key: str, value: Any, problem: str, allowed: str | None = None) -> CheckpointError:
    """One line: the file, the field, its value (ASCII, short), the problem and what is allowed there."""
    return CheckpointError(f"{path}: checkpoint field {key!r} = {_shown(value)}: {problem} "
                           f"(allowed: {allowed or _allowed(key)})")


def _key(loc: tuple[int | str, ...]) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def check_json(path: Path | str, key: str, value: Any) -> None:
    """``value`` is JSON-like with finite numbers, at most :data:`MAX_DEPTH` levels deep (iterative: no
    recursion limit to hit); else the error naming the first bad key."""
    stack: list[tuple[str, Any, int]] = [(key, value, 0)]
    while stack:
        k, v, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise field_error(path, k, v, f"nested deeper than {MAX_DEPTH} levels", "flatter tables")
        if isinstance(v, dict):
            for kk, vv in v.items():
                if not isinstance(kk, str):
                    raise field_error(path, f"{k}.{kk!r}", kk, "a key that is not text", "text keys")
                stack.append((f"{k}.{kk}", vv, depth + 1))
        elif isinstance(v, list | tuple):
            stack.extend((f"{k}[{i}]", vv, depth + 1) for i, vv in enumerate(v))
        elif isinstance(v, float) and not math.isfinite(v):
            raise field_error(path, k, v, "not a finite number", _allowed(k, "finite numbers only"))
        elif not isinstance(v, str | int | float | bool) and v is not None:
            raise field_error(path, k, type(v).__name__, "not JSON-like data",
                              "text, numbers, true/false, null, lists and tables")


def check_checkpoint(doc: Any, path: Path | str) -> CheckpointMeta:
    """The checkpoint dict ``doc`` (as ``torch.load`` gave it) validated, weights included; raises
    :class:`CheckpointError` naming the first bad field. Builds no network."""
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise CheckpointError(f"{path}: not an auvlink PointNet checkpoint (format {FORMAT!r} expected)")
    for key in ("synthesis", "train", "metrics", "calibration"):
        check_json(path, key, doc.get(key, {}))
    try:
        meta = CheckpointMeta.model_validate(doc)
    except ValidationError as exc:
        err = exc.errors(include_url=False)[0]
        key = _key(tuple(err["loc"])) or "<checkpoint>"
        allowed = None
        if err["type"] == "extra_forbidden":  # an unknown key: the keys of its table
            table = NetworkMeta if key.startswith("model_config.") else CheckpointMeta
            allowed = f"the keys {', '.join(table.model_json_schema(by_alias=True)['properties'])}"
        if err["type"] == "missing":
            raise CheckpointError(f"{path}: checkpoint field {key!r} is missing (allowed: {_allowed(key)})") from exc
        raise field_error(path, key, err.get("input"), err["msg"].removeprefix("Value error, "), allowed) from exc
    names, n_out = meta.class_names, meta.network.num_classes
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise field_error(path, "class_names", dup, "a name given twice")
    if len(names) != n_out:
        raise field_error(path, "class_names", list(names), f"{len(names)} names for {n_out} network outputs",
                          f"exactly model_config.num_classes = {n_out} names")
    check_weights(path, meta)
    return meta


def network_config(meta: CheckpointMeta) -> PointNetConfig:
    return PointNetConfig.from_dict(meta.network.model_dump())


def check_weights(path: Path | str, meta: CheckpointMeta) -> None:
    """Every weight table holds tensors only, all finite (their names and shapes are checked when they are
    loaded into the network, whose size :class:`NetworkMeta` bounds)."""
    tables = [("state_dict", meta.state_dict)] + [(f"members[{i}]", m) for i, m in enumerate(meta.members)]
    for where, table in tables:
        for name, t in table.items():
            if not isinstance(t, torch.Tensor):
                raise field_error(path, f"{where}.{name}", type(t).__name__, "not a tensor", "tensors only")
            if t.is_floating_point() and not bool(torch.isfinite(t).all()):
                raise field_error(path, f"{where}.{name}", f"tensor{tuple(t.shape)}", "holds NaN or inf",
                                  "finite weights")
