"""Export a mission log for people: navigation as CSV, sonar frames as fan-shaped PNG images.

Frames are decoded through the same framers and codecs as live operation (:class:`Replay`, fast).

* ``DIR/<channel>.csv``: one row per decoded record of a non-image channel: ``t_host_s`` (UTC
  s), ``t_sensor_s`` and the columns of the format's ``to_json`` (SI units); short lists become
  ``name_0, name_1, ...``, nested tables ``name.key``; long arrays (profiles, images) are left out.
* ``DIR/<channel>/frame_NNNNNN.png``: sonar frames as fans (see :mod:`logs_format.fan`), and
  ``DIR/<channel>/frames.csv`` (file, times, picture extent in metres).
"""

from __future__ import annotations

import csv
import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import numpy as np

from auvlink import formats
from auvlink.jsonutil import to_jsonable
from auvlink.safe_names import UniqueNames, path_inside
from logs_format.fan import FanGrid, fan_grid, save_fan_png, sonar_geometry
from logs_format.profile import LogError
from logs_format.replay import Replay

MAX_LIST = 16


@dataclass
class ExportResult:
    out: Path
    csv_rows: dict[str, int] = field(default_factory=dict)
    png_frames: dict[str, int] = field(default_factory=dict)
    files: list[Path] = field(default_factory=list)
    decode_errors: dict[str, int] = field(default_factory=dict)
    loss: str = ""  # one line: what the log lost ("complete" when nothing)
    loss_report: dict[str, Any] = field(default_factory=dict)  # the log's LossReport as JSON

    def as_dict(self) -> dict[str, Any]:
        return {"out": str(self.out), "csv_rows": self.csv_rows, "png_frames": self.png_frames,
                "files": [str(p) for p in self.files], "decode_errors": self.decode_errors, "loss": self.loss,
                "loss_report": self.loss_report}


def flatten(obj: Any, prefix: str = "") -> dict[str, Any]:
    """A JSON-ready dict -> flat CSV columns (see the module docstring)."""
    out: dict[str, Any] = {}
    if isinstance(obj, dict):
        for key, value in obj.items():
            out.update(flatten(value, f"{prefix}.{key}" if prefix else str(key)))
    elif isinstance(obj, list):
        if len(obj) <= MAX_LIST and all(not isinstance(v, list | dict) for v in obj):
            for i, value in enumerate(obj):
                out[f"{prefix}_{i}"] = "" if value is None else value
    else:
        out[prefix] = "" if obj is None else obj
    return out


def record_columns(record: Any, fmt: str) -> dict[str, Any]:
    to_json = formats.get(fmt).to_json
    if to_json is not None:
        data = to_jsonable(to_json(record))
    elif dataclasses.is_dataclass(record) and not isinstance(record, type):
        data = to_jsonable(record)
    else:
        data = {"value": to_jsonable(record)}
    return flatten(data)


class _Csv:
    def __init__(self, path: Path) -> None:
        self.path = path
        self.file: IO[str] = open(path, "w", newline="")
        self.writer: csv.DictWriter[str] | None = None
        self.rows = 0

    def write(self, row: dict[str, Any]) -> None:
        if self.writer is None:
            self.writer = csv.DictWriter(self.file, fieldnames=list(row), restval="", extrasaction="ignore")
            self.writer.writeheader()
        self.writer.writerow(row)
        self.rows += 1

    def close(self) -> None:
        self.file.close()


def _check_channels(wanted: set[str], present: Iterable[Any], path: str | Path) -> None:
    """Refuse a channel name the log does not hold (a typo exported the other channels' navigation only)."""
    names = {str(n) for ch in present for n in (ch.topic, ch.device) if n}
    unknown = sorted(wanted - names)
    if unknown:
        raise LogError(f"--channels: no channel {unknown[0]!r} in {path} (its channels: {', '.join(sorted(names))})")


def export_log(
    path: str | Path,
    out_dir: str | Path,
    *,
    channels: Iterable[str] | None = None,
    sonar_every: int = 1,
    max_sonar_frames: int | None = None,
    png: bool = True,
) -> ExportResult:
    """Write CSV and PNG files of the log at ``path`` into ``out_dir`` (see the module docstring)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    result = ExportResult(out)
    tables: dict[str, _Csv] = {}
    grids: dict[str, tuple[bytes, FanGrid]] = {}
    seen: dict[str, int] = {}
    names = UniqueNames(fallback="channel")  # devices whose names clean alike get files of their own
    try:
        with Replay(path, channels=channels) as rep:
            if channels is not None:
                _check_channels(set(channels), rep.reader.discover_channels().values(), path)
            for sample in rep.samples():
                geometry = sonar_geometry(sample.record)
                name = names.name_for(sample.device, ".csv" if geometry is None else "")
                base = {"t_host_s": sample.t_host_ns * 1e-9,
                        "t_sensor_s": "" if sample.t_sensor is None else sample.t_sensor}
                if geometry is None:
                    if name not in tables:
                        tables[name] = _Csv(path_inside(out, f"{name}.csv"))
                        result.files.append(tables[name].path)
                    tables[name].write({**base, **record_columns(sample.record, sample.format)})
                    continue
                k = seen.get(name, 0)
                seen[name] = k + 1
                done = result.png_frames.get(name, 0)
                full = max_sonar_frames is not None and done >= max_sonar_frames
                if not png or k % max(1, sonar_every) or full:
                    continue
                image, ranges, azimuths = geometry
                key = ranges.tobytes() + azimuths.tobytes()
                if name not in grids or grids[name][0] != key:
                    grids[name] = (key, fan_grid(ranges, azimuths))
                grid = grids[name][1]
                folder = path_inside(out, name)
                if name not in tables:
                    folder.mkdir(exist_ok=True)
                    tables[name] = _Csv(folder / "frames.csv")
                    result.files.append(tables[name].path)
                file = folder / f"frame_{k:06d}.png"
                save_fan_png(file, np.asarray(image), grid)
                tables[name].write({**base, "file": file.name, "x_min_m": grid.x_min, "x_max_m": grid.x_max,
                                    "y_min_m": grid.y_min, "y_max_m": grid.y_max, "px_per_m": grid.px_per_m})
                result.png_frames[name] = done + 1
            for dec in rep.decoders.values():
                result.decode_errors[dec.name] = dec.stats.decode_errors
            result.loss = rep.loss.describe()
            result.loss_report = rep.loss.to_json()
    finally:
        for table in tables.values():
            table.close()
    result.csv_rows = {name: t.rows for name, t in tables.items() if t.path.name != "frames.csv"}
    return result
