"""Training settings from TOML (``classify/data/train_default.toml`` is the shipped model's).

Tables: ``[synthesis]`` (fields of :class:`SynthesisSettings`; ``heading_step_deg`` may stand for
``headings_deg``), ``[train]`` (fields of :class:`TrainConfig`), ``[train.augment]``
(:class:`AugmentConfig`), ``[surveys]`` (:class:`~classify.training.survey_tuning.SurveySettings`: the survey
stage), ``[decision]`` (:class:`~classify.training.decision_fit.DecisionSettings`: the decision model's surveys)
and ``[quick]`` (overrides of ``train`` and ``synthesis`` keys, and of ``surveys`` and ``decision_surveys``, for a
reduced-budget run, e.g. ``epochs``, ``heading_step_deg``).
"""

from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, ConfigDict, Field, create_model

from auvlink.errors import AuvlinkError, ConfigError
from auvlink.sim.acoustics import PROFILES
from auvlink.sim.scene import SIMULATED_MODELS
from auvlink.validation import CONFIG, Boolean, Integer, Number, Text, read_toml, validate
from classify.checkpoint_meta import MAX_MEMBERS, MAX_POINTS, MAX_WIDTH
from classify.training.augment import AugmentConfig
from classify.training.decision_fit import DecisionSettings
from classify.training.survey_tuning import SurveySettings
from classify.training.synthesis import SynthesisSettings
from classify.training.train import TrainConfig

DEFAULT_CONFIG = Path(__file__).resolve().parents[1] / "data" / "train_default.toml"

#: finest heading step: 3600 headings per class, 180 x the shipped 20 deg (a finer step only multiplies the synthesis)
MIN_HEADING_STEP_DEG = 0.1
#: bounds of the training settings (ge, le) or ("gt", lo, le) where a size could exhaust memory
_BOUNDS: dict[str, tuple[Any, ...]] = {
    "epochs": (1, 100_000), "batch_size": (1, 65_536), "patience": (0, 100_000), "threads": (1, 1024),
    "n_points": (1, MAX_POINTS), "members": (1, MAX_MEMBERS + 1), "candidates": (1, 10_000_000),
    "copies": (1, 10_000), "rays_per_beam": (1, 1024),
    "min_run": (1, 10_000), "seed": (0, 2**63 - 1), "val_fraction": (0.0, 0.99), "dropout": (0.0, 0.99),
    "lr": ("gt", 0.0, 10.0), "width": ("gt", 0.0, MAX_WIDTH), "spread_deg": ("gt", 0.0, 90.0),
    "heading_step_deg": (MIN_HEADING_STEP_DEG, 360.0), "step_m": ("gt", 0.0, 100.0), "bin_m": ("gt", 0.0, 100.0),
    "cut_prob": (0.0, 1.0), "dropout_max": (0.0, 1.0), "fused_prob": (0.0, 1.0), "partial_prob": (0.0, 1.0),
    "clutter_clouds": (0, 100_000), "clutter_rays_per_beam": (2, 1024), "clutter_line_m": ("gt", 0.0, 1000.0),
    "clutter_poll_m": ("gt", 0.0, 100.0), "run_span_m": (0.0, 10.0), "object_patch_views": (0, 100_000),
    "object_patch_lead_m": (0.0, 100.0), "object_patch_offset_m": ("gt", 0.0, 100.0),
    # as auvlink.cli.survey_options' MAX_SURVEYS and MAX_WORKERS (each survey minutes of work; 0: no survey stage)
    "surveys": (0, 10_000), "workers": (1, 256),
    "ideal_every": (0, 10_000), "synthesized_share": (0.0, 0.95),  # 0.95: a stage of 20 synthesized clouds to one
    "decision_surveys": (0, 10_000), "holdout": (0.0, 0.9),
    "c": ("gt", 0.0, 1e6),  # the regression's inverse penalty: 1e6 is no penalty at all
}
#: bounds of each value of a [low, high] pair or a list (the pair itself must be in order)
_BOUNDS.update({
    "tilts_deg": ("gt", 0.0, 90.0), "noise_fraction": (0.0, 1.0), "altitude_m": ("gt", 0.0, 1000.0),
    "fused_passes": (1, 10), "clutter_lines": (1, 100), "object_patch_lines": (1, 100), "scale": ("gt", 0.0, 10.0),
    "jitter_sigma": (0.0, 10.0), "jitter_clip": (0.0, 10.0),
    "dr_prob": (0.0, 1.0), "dr_nominal_edge_prob": (0.0, 1.0), "dr_edge_error_deg": (0.0, 20.0),
    "dr_speckle_looks": (0.0, 64.0), "dr_pattern_weights": (0.0, 1000.0), "dr_extent": (1.0, 4.0),
    "dr_edge_level_db": (-60.0, 0.0), "dr_azimuth_width_beams": ("gt", 0.0, 4.0), "dr_sidelobe_db": (-80.0, -5.0),
    "dr_pulse_bins": (1, 20), "dr_threshold_db": (-30.0, 30.0), "dr_tvg_db_per_m": (-10.0, 10.0),
    "dr_seabed_bias_m": (-2.0, 2.0),
})
#: the words a text setting takes (synthesis_settings: any other word silently meant the other mode)
_CHOICES: dict[str, tuple[str, ...]] = {"mode": ("paper", "scan"), "detect": ("cos", "energy"),
                                        "correction": ("none", "arc"), "z_ref": ("mean", "seabed"),
                                        "acoustics": ("random", *PROFILES), "sonar": ("random", *SIMULATED_MODELS)}
_LEAF = {float: Number, int: Integer, bool: Boolean, str: Text}


def _values_check(name: str) -> Any:
    """A validator of a [low, high] pair or a list: not empty, each value in ``name``'s bounds, a pair in order."""
    bounds = _BOUNDS.get(name)

    def check(values: tuple[float, ...]) -> tuple[float, ...]:
        if not values:
            raise ValueError("needs at least one value")
        if bounds is not None:
            lo, hi, low_ok = (bounds[1], bounds[2], False) if bounds[0] == "gt" else (bounds[0], bounds[1], True)
            bad = [v for v in values if not ((v >= lo if low_ok else v > lo) and v <= hi)]
            if bad:
                raise ValueError(f"{bad[0]} is out of range (use values in {'[' if low_ok else '('}{lo}, {hi}])")
        if len(values) == 2 and values[0] > values[1]:
            raise ValueError(f"[{values[0]}, {values[1]}] is not a [low, high] range: write the smaller value first")
        return values

    return AfterValidator(check)


def _leaf(tp: Any, name: str) -> Any:
    if typing.get_origin(tp) is tuple:
        args = typing.get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:  # a list (tilts, headings)
            items = tuple[_leaf(args[0], ""), ...]  # type: ignore[misc,valid-type]
            return Annotated[items, Field(max_length=100_000), _values_check(name)]
        return Annotated[tuple.__class_getitem__(tuple(_leaf(a, "") for a in args)), _values_check(name)]
    if tp is str and name in _CHOICES:
        return Literal[_CHOICES[name]]
    base = _LEAF.get(tp, tp)
    bounds = _BOUNDS.get(name)
    if bounds is None:
        return base
    if bounds[0] == "gt":
        return Annotated[base, Field(gt=bounds[1], le=bounds[2])]
    return Annotated[base, Field(ge=bounds[0], le=bounds[1])]


def table_model(cls: type, name: str, extra: dict[str, Any] | None = None) -> Any:
    """A pydantic model of the TOML table that fills the dataclass ``cls`` (every key optional)."""
    hints = typing.get_type_hints(cls)
    fields: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        if not f.init or f.name == "augment":
            continue
        fields[f.name] = (_leaf(hints[f.name], f.name) | None, None)
    fields.update(extra or {})
    return create_model(name, __config__=ConfigDict(**CONFIG), **fields)


AugmentTable = table_model(AugmentConfig, "AugmentTable")
SynthesisTable = table_model(SynthesisSettings, "SynthesisTable",
                             {"heading_step_deg": (_leaf(float, "heading_step_deg") | None, None)})
TrainTable = table_model(TrainConfig, "TrainTable", {"augment": (AugmentTable | None, None)})
QuickTable = create_model("QuickTable", __config__=ConfigDict(**CONFIG),  # type: ignore[call-overload]
                          **{k: (v.annotation, None) for k, v in {**SynthesisTable.model_fields,
                                                                  **TrainTable.model_fields}.items()
                             if k != "augment"}, surveys=(_leaf(int, "surveys") | None, None),
                          decision_surveys=(_leaf(int, "decision_surveys") | None, None))
SurveysTable = table_model(SurveySettings, "SurveysTable")
DecisionTable = table_model(DecisionSettings, "DecisionTable")
TrainFile = create_model("TrainFile", __config__=ConfigDict(**CONFIG), synthesis=(SynthesisTable | None, None),
                         train=(TrainTable | None, None), quick=(QuickTable | None, None),
                         surveys=(SurveysTable | None, None), decision=(DecisionTable | None, None))


@dataclass(frozen=True)
class TrainSettings:
    synthesis: SynthesisSettings
    train: TrainConfig
    source: str = ""
    surveys: SurveySettings = field(default_factory=SurveySettings)
    decision: DecisionSettings = field(default_factory=DecisionSettings)


def _synthesis(table: dict[str, Any]) -> SynthesisSettings:
    t = dict(table)
    step = t.pop("heading_step_deg", None)
    if step is not None:
        t["headings_deg"] = [float(h) for h in range(0, 360, int(step))] if float(step).is_integer() else \
            [i * float(step) for i in range(int(360 // float(step)))]
    return SynthesisSettings.from_dict(t)


def load_train_settings(path: Path | None = None, quick: bool = False) -> TrainSettings:
    """Settings from ``path`` (the shipped defaults when None); ``quick`` applies ``[quick]``.

    The file is validated by :data:`TrainFile` (``docs/schemas/train.schema.json``); the dataclasses
    are then built from the values as written (so the shipped model's cache keys stay the same).
    """
    path = Path(path) if path is not None else DEFAULT_CONFIG
    doc, _ = read_toml(path, str(path))
    validate(TrainFile, doc)
    syn_t, train_t = dict(doc.get("synthesis", {})), dict(doc.get("train", {}))
    surveys_t, decision_t = dict(doc.get("surveys", {})), dict(doc.get("decision", {}))
    if quick:
        for k, v in doc.get("quick", {}).items():
            if k == "surveys":
                surveys_t[k] = v
            elif k == "decision_surveys":
                decision_t["surveys"] = v
            elif k in SynthesisSettings.__dataclass_fields__ or k == "heading_step_deg":
                syn_t[k] = v
            else:
                train_t[k] = v
    try:
        return TrainSettings(_synthesis(syn_t), TrainConfig.from_dict(train_t), str(path),
                             SurveySettings.from_dict(surveys_t), DecisionSettings.from_dict(decision_t))
    except (TypeError, ValueError) as exc:
        raise ConfigError(str(path), f"bad training settings: {exc}", "check the values") from exc


def with_overrides(s: TrainSettings, epochs: int | None = None, seed: int | None = None,
                   threads: int | None = None, surveys: int | None = None,
                   decision_surveys: int | None = None) -> TrainSettings:
    """``s`` with the command line's ``--epochs``, ``--seed``, ``--threads`` (each checked as in ``[train]``),
    ``--surveys`` (as in ``[surveys]``) and ``--decision-surveys`` (``[decision] surveys``)."""
    for option, value in (("epochs", epochs), ("seed", seed), ("threads", threads), ("surveys", surveys),
                          ("decision_surveys", decision_surveys)):
        lo, hi = _BOUNDS[option]
        if value is not None and not lo <= value <= hi:
            raise AuvlinkError(f"--{option.replace('_', '-')} must be an integer in [{lo}, {hi}], got {value}")
    train = s.train
    if threads is not None:
        train = replace(train, threads=threads)
    if epochs is not None:
        train = replace(train, epochs=epochs)
    if seed is not None:
        train = replace(train, seed=seed)
    if surveys is not None:
        s = replace(s, surveys=replace(s.surveys, surveys=surveys))
    if decision_surveys is not None:
        s = replace(s, decision=replace(s.decision, surveys=decision_surveys))
    return replace(s, train=train)
