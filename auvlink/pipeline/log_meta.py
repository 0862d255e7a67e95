"""What the pipeline takes from a mission log's metadata records, validated like the vehicle configuration.

A log is outside input. Its values go through pydantic models built from :mod:`auvlink.validation` (strict,
finite numbers, ranges) before use:

* ``ground_truth.objects``: each entry as a :class:`StoredTruthObject` (class, position NED within
  :data:`MAX_NED_M`, heading, WGS84 latitude / longitude); an entry that fails (NaN, 1e308, a string, a
  missing field) is skipped and counted (:class:`Truth`), the others are kept.
* ``live_pipeline``: the engine settings a live run stored (:class:`~auvlink.pipeline.engine_config.EngineConfig`,
  whose fields carry their ranges; a bad key falls back to its default) and its time origin ``t0_ns``, kept
  only within :data:`T0_MARGIN_NS` of the log's own time span.

Each fallback gives one warning line naming the key and the default used.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Annotated, Any

from pydantic import ConfigDict, Field
from pydantic.dataclasses import dataclass as pydantic_dataclass

from auvlink.errors import ConfigError
from auvlink.pipeline.engine_config import EngineConfig
from auvlink.validation import Latitude, Longitude, Number, Text, validate

#: a local NED frame spans at most 10,000 km (a quarter of the Earth's circumference): beyond, a flat
#: frame means nothing, and squared distances of such numbers overflow float64 no sooner than 1e154 m
MAX_NED_M = 1e7
#: live stores its clock reading at start-up, before the classifier loads and the ports open (seconds);
#: an origin more than an hour before the log's first message or after its last is not that reading
T0_MARGIN_NS = 3600 * 10**9
LIVE_META = "live_pipeline"

Coordinate = Annotated[Number, Field(ge=-MAX_NED_M, le=MAX_NED_M)]


@pydantic_dataclass(frozen=True, config=ConfigDict(extra="ignore", allow_inf_nan=False))
class StoredTruthObject:
    """One entry of ``ground_truth.objects`` as the simulator writes it (other keys are ignored)."""

    class_name: Text
    position: Annotated[list[Coordinate], Field(min_length=2, max_length=3)]  # north, east[, down]
    heading_deg: Annotated[Number, Field(ge=-360.0, le=360.0)] = 0.0
    latitude: Latitude | None = None
    longitude: Longitude | None = None


@dataclass(frozen=True)
class TruthObject:
    """One object of a simulated mission's ground truth (world frame NED, m)."""

    class_name: str
    position_ned: tuple[float, float, float]
    heading_deg: float = 0.0
    latitude: float | None = None  # WGS84 deg (the simulator's truth carries them with its datum)
    longitude: float | None = None


@dataclass(frozen=True)
class Truth:
    """The usable truth objects, how many entries were skipped and why the first one was."""

    objects: tuple[TruthObject, ...] = ()
    skipped: int = 0
    problem: str = ""


def truth_objects(gt: object) -> Truth:
    """The objects of a ``ground_truth`` record (keys ``class`` or ``class_name``, ``position_ned`` or
    ``position``; a 2-vector position has an unknown depth, NaN), each validated alone."""
    objects = gt.get("objects") if isinstance(gt, Mapping) else None
    if not isinstance(objects, list):
        bad = isinstance(gt, Mapping) and objects is not None
        return Truth(skipped=int(bad), problem="ground_truth.objects: not a list" if bad else "")
    out: list[TruthObject] = []
    skipped, problem = 0, ""
    for i, obj in enumerate(objects):
        try:
            if not isinstance(obj, Mapping):
                raise ConfigError("", f"expected a table, got {type(obj).__name__}", "")
            entry = validate(StoredTruthObject, {
                **{k: v for k, v in obj.items() if k in ("heading_deg", "latitude", "longitude")},
                "class_name": obj.get("class") or obj.get("class_name"),
                "position": obj.get("position_ned") or obj.get("position")}, f"ground_truth.objects[{i}].")
        except ConfigError as exc:
            skipped += 1
            problem = problem or f"key {exc.key!r}: {exc.problem}"
            continue
        p = (*entry.position, float("nan"))[:3]
        out.append(TruthObject(entry.class_name, (float(p[0]), float(p[1]), float(p[2])), float(entry.heading_deg),
                               entry.latitude, entry.longitude))
    return Truth(tuple(out), skipped, problem)


def _line(exc: ConfigError, default: str) -> str:
    return f"log metadata key {exc.key!r}: {exc.problem}{f' ({exc.fix})' if exc.fix else ''}; using {default}"


def engine_settings(stored: object, key: str = f"{LIVE_META}.engine") -> tuple[EngineConfig, list[str]]:
    """The :class:`EngineConfig` of stored settings: each bad key replaced by its default (one warning each)."""
    if not isinstance(stored, Mapping):
        return EngineConfig(), [f"log metadata key {key!r}: not a table; using the default engine settings"]
    names = {f.name for f in fields(EngineConfig)}
    data = {k: v for k, v in stored.items() if k in names}
    warnings: list[str] = []
    defaults = EngineConfig()
    for _ in range(len(names) + 1):
        try:
            return validate(EngineConfig, data, f"{key}."), warnings
        except ConfigError as exc:
            name = exc.key.rpartition(".")[2]
            if name not in data:  # not one key's value: give up on them all
                return defaults, [*warnings, _line(exc, "the default engine settings")]
            del data[name]
            warnings.append(_line(exc, f"the default {getattr(defaults, name)!r}"))
    return defaults, warnings


def live_t0(stored: object, start_ns: int | None, end_ns: int | None) -> tuple[int | None, list[str]]:
    """The time origin a live run stored (``live_pipeline.t0_ns``), or None (the engine takes its first
    sample's time) with a warning when it is not a whole number of ns near the log's span."""
    if stored is None:
        return None, []
    key = f"{LIVE_META}.t0_ns"
    if isinstance(stored, bool) or not isinstance(stored, int):
        return None, [f"log metadata key {key!r}: expected a whole number of ns, got {stored!r}; "
                      "using the time of the first sample"]
    lo = (start_ns if start_ns is not None else 0) - T0_MARGIN_NS
    hi = (end_ns if end_ns is not None else 2**63 - 1)
    if not max(lo, 0) <= stored <= hi:
        return None, [f"log metadata key {key!r}: {stored} is not within an hour of the log's messages "
                      f"(use a value in [{max(lo, 0)}, {hi}]); using the time of the first sample"]
    return stored, []


def live_settings(meta: Mapping[str, Any], start_ns: int | None = None, end_ns: int | None = None
                  ) -> tuple[EngineConfig | None, int | None, list[str]]:
    """The engine settings and time origin a live run stored (None, None without a ``live_pipeline``
    record) and the warnings of what was replaced by a default."""
    rec = meta.get(LIVE_META)
    if not isinstance(rec, Mapping):
        warn = [] if rec is None else [f"log metadata key {LIVE_META!r}: not a table; using the defaults"]
        return None, None, warn
    t0, warnings = live_t0(rec.get("t0_ns"), start_ns, end_ns)
    if rec.get("engine") is None or rec.get("engine") == {}:
        return None, t0, warnings
    cfg, more = engine_settings(rec.get("engine"))
    return cfg, t0, warnings + more
