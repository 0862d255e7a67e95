"""Training settings from TOML (``classify/data/train_default.toml`` is the shipped model's).

Tables: ``[synthesis]`` (fields of :class:`SynthesisSettings`; ``heading_step_deg`` may stand for
``headings_deg``), ``[train]`` (fields of :class:`TrainConfig`), ``[train.augment]``
(:class:`AugmentConfig`) and ``[quick]`` (overrides of ``train`` and ``synthesis`` keys for a
reduced-budget run, e.g. ``epochs``, ``heading_step_deg``).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from auvlink.errors import ConfigError
from classify.synthesis import SynthesisSettings
from classify.train import TrainConfig

DEFAULT_CONFIG = Path(__file__).resolve().parent / "data" / "train_default.toml"


@dataclass(frozen=True)
class TrainSettings:
    synthesis: SynthesisSettings
    train: TrainConfig
    source: str = ""


def _synthesis(table: dict[str, Any]) -> SynthesisSettings:
    t = dict(table)
    step = t.pop("heading_step_deg", None)
    if step is not None:
        if not 0 < float(step) <= 360:
            raise ConfigError("synthesis.heading_step_deg", f"{step} not in (0, 360]")
        t["headings_deg"] = [float(h) for h in range(0, 360, int(step))] if float(step).is_integer() else \
            [i * float(step) for i in range(int(360 // float(step)))]
    unknown = set(t) - set(SynthesisSettings.__dataclass_fields__)
    if unknown:
        raise ConfigError(f"synthesis.{sorted(unknown)[0]}", "unknown key")
    return SynthesisSettings.from_dict(t)


def _train(table: dict[str, Any]) -> TrainConfig:
    unknown = set(table) - set(TrainConfig.__dataclass_fields__)
    if unknown:
        raise ConfigError(f"train.{sorted(unknown)[0]}", "unknown key")
    return TrainConfig.from_dict(table)


def load_train_settings(path: Path | None = None, quick: bool = False) -> TrainSettings:
    """Settings from ``path`` (the shipped defaults when None); ``quick`` applies ``[quick]``."""
    path = Path(path) if path is not None else DEFAULT_CONFIG
    try:
        doc = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(str(path), f"cannot read training settings: {exc}") from exc
    syn_t, train_t = dict(doc.get("synthesis", {})), dict(doc.get("train", {}))
    if quick:
        for k, v in doc.get("quick", {}).items():
            if k in SynthesisSettings.__dataclass_fields__ or k == "heading_step_deg":
                syn_t[k] = v
            else:
                train_t[k] = v
    return TrainSettings(_synthesis(syn_t), _train(train_t), str(path))


def with_overrides(s: TrainSettings, epochs: int | None = None, seed: int | None = None,
                   threads: int | None = None) -> TrainSettings:
    train = s.train
    if threads is not None:
        train = replace(train, threads=threads)
    if epochs is not None:
        train = replace(train, epochs=epochs)
    if seed is not None:
        train = replace(train, seed=seed)
    return replace(s, train=train)
