"""Write a run's outputs: ``detections.jsonl``, ``cloud.ply``, one PLY per object, ``summary.json``, and
the GIS files of :mod:`auvlink.pipeline.gis` (``track.csv``; with a georeference ``detections.geojson``,
``track.geojson``, ``detections.kml``). ``summary.json``'s ``georef`` says which frame the positions are
in (``frame``: ``site`` or ``first_navigation_sample``), the datum, the anchor, the closure error and
the GNSS fixes used and rejected.

:class:`DetectionStream` writes each detection as it is made (its PLY, then its line, flushed), so a
live run's folder holds every object finalized so far even if the run is killed; :func:`write_outputs`
writes the whole folder at the end, each file under a temporary name renamed when whole
(:func:`auvlink.atomic.atomic_path`), so a crash never leaves a half file of a name it writes.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from auvlink.atomic import atomic_path
from auvlink.errors import OutputError
from auvlink.jsonutil import to_jsonable
from auvlink.pipeline.results import Detection, MissionResult
from auvlink.pipeline.scoring import score_detections
from recon.ply import write_ply


def object_ply_name(det: Detection) -> str:
    return f"objects/object_{det.id:03d}_{det.class_name}.ply"


class DetectionStream:
    """Appends one detection at a time to ``DIR/detections.jsonl`` (and its PLY); see the module doc."""

    def __init__(self, out_dir: Path) -> None:
        self.out_dir = out_dir
        (out_dir / "objects").mkdir(parents=True, exist_ok=True)
        self.path = out_dir / "detections.jsonl"
        self.path.write_text("")
        self.count = 0
        self.error: OSError | None = None  # the first write that failed (disk full): streaming stops there

    def __call__(self, det: Detection) -> None:
        if self.error is not None:
            return
        name = object_ply_name(det)
        try:
            write_ply(self.out_dir / name, det.points)
            with open(self.path, "a") as f:
                f.write(json.dumps(to_jsonable(det.to_json(name)), allow_nan=False) + "\n")
                f.flush()
        except OSError as exc:  # the run goes on; write_outputs tries the whole folder again at the end
            self.error = exc
            return
        self.count += 1


def _write(out_dir: Path, name: str, write: Callable[[Path], Any], unwritten: list[str] | None) -> None:
    """Write ``out_dir/name`` atomically; with ``unwritten`` a failure is listed there instead of raised."""
    try:
        with atomic_path(out_dir / name) as tmp:
            write(tmp)
    except OSError as exc:
        if unwritten is None:
            raise OutputError(f"cannot write {out_dir / name}: {exc.strerror or exc}") from exc
        unwritten.append(f"{name} ({exc.strerror or exc})")


def write_outputs(result: MissionResult, out_dir: Path, *, keep_going: bool = False) -> dict[str, Any]:
    """Write the files of ARCHITECTURE.md's output folder; returns the summary dict. A file that cannot
    be written raises :class:`OutputError`; with ``keep_going`` (a live run: write what can be written)
    the others are still written and the summary lists the failed ones under ``unwritten``."""
    unwritten: list[str] | None = [] if keep_going else None
    out_dir.mkdir(parents=True, exist_ok=True)
    obj_dir = out_dir / "objects"
    obj_dir.mkdir(exist_ok=True)
    lines = []
    for det in result.detections:
        name = object_ply_name(det)
        _write(out_dir, name, functools.partial(write_ply, points=det.points), unwritten)
        lines.append(json.dumps(to_jsonable(det.to_json(name)), allow_nan=False))
    _write(out_dir, "detections.jsonl", lambda p: p.write_text("".join(line + "\n" for line in lines)),
           unwritten)
    cloud = (np.concatenate([d.points for d in result.detections]) if result.detections
             else np.zeros((0, 3)))
    _write(out_dir, "cloud.ply", lambda p: write_ply(p, cloud), unwritten)
    from auvlink.pipeline.gis import write_gis

    gis_files = write_gis(result, lambda name, fn: _write(out_dir, name, fn, unwritten))
    summary = {
        "log": str(result.log),
        "detections": len(result.detections),
        "mode": result.mode,
        "timings": result.timings,
        "latency": result.latency,
        "drops": result.drops,
        "events": result.events,
        "engine": result.engine,
        "recon": result.recon_stats,
        "devices": result.replay_stats,
        "log_loss": result.loss_json(),
        "scores": score_detections(result),
        "georef": {**result.georef, "files": gis_files},
    }
    if unwritten is not None:
        summary["unwritten"] = unwritten  # the summary itself last: what it says is all that failed before it
    text = json.dumps(to_jsonable(summary), indent=2, allow_nan=False) + "\n"
    _write(out_dir, "summary.json", lambda p: p.write_text(text), unwritten)
    return summary
