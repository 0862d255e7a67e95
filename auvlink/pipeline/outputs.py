"""Write a run's outputs: ``detections.jsonl``, ``cloud.ply``, one PLY per object, ``results.mcap``
(the results in Foxglove schemas, :mod:`auvlink.pipeline.results_mcap`), ``summary.json``, and the GIS
files of :mod:`auvlink.pipeline.gis` (``track.csv``; with a georeference ``detections.geojson``,
``track.geojson``, ``detections.kml``). ``summary.json``'s ``georef`` says which frame the positions are
in (``frame``: ``site`` or ``first_navigation_sample``), the datum, the anchor, the closure error and
the GNSS fixes used and rejected.

PLY files: per point x, y, z (double, m), ``object_id`` (uint) and ``time`` (double, s since the UNIX
epoch, UTC: when the point was seen). Their frame is the world frame W, local NED (x north, y east,
z down) by default; ``ply_frame="zup"`` (``--ply-frame zup``) writes them in the ENU-like z-up frame
common viewers expect (x east, y north, z up = -down; same origin), as their header comment says.

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
from auvlink.errors import AuvlinkError, OutputError
from auvlink.jsonutil import to_jsonable
from auvlink.pipeline.results import Detection, MissionResult
from auvlink.pipeline.results_mcap import write_results_mcap
from auvlink.pipeline.truth_scores import score_detections
from auvlink.safe_names import path_inside, safe_name
from recon.ply import NED_COMMENT, write_ply

#: ``--ply-frame`` choices: the world frame NED (the default) or ENU-like z-up
PLY_FRAMES = ("ned", "zup")
ZUP_COMMENT = "auvlink recon, z-up frame: x east, y north, z up (m), origin of the world frame NED"


def object_ply_name(det: Detection) -> str:
    """``objects/object_<id>_<class>.ply``, the class name made a safe file-name component
    (:func:`auvlink.safe_names.safe_name`: a checkpoint's class names are data); the id keeps it unique."""
    return f"objects/object_{det.id:03d}_{safe_name(det.class_name, 'unknown')}.ply"


def check_ply_frame(frame: str) -> str:
    if frame not in PLY_FRAMES:
        raise AuvlinkError(f"--ply-frame must be one of {', '.join(PLY_FRAMES)}, got {frame!r}")
    return frame


def write_points_ply(path: Path, detections: list[Detection], frame: str = "ned") -> None:
    """The points of ``detections`` with ``object_id`` and ``time`` (see the module docstring)."""
    check_ply_frame(frame)
    pts = (np.concatenate([np.asarray(d.points, dtype=np.float64).reshape(-1, 3) for d in detections])
           if detections else np.zeros((0, 3)))
    ids = np.concatenate([np.full(len(d.points), d.id, np.uint32) for d in detections]) if detections \
        else np.zeros(0, np.uint32)
    times = [np.asarray(d.times, dtype=np.float64) if np.shape(d.times) == (len(d.points),)
             else np.full(len(d.points), d.t_first) for d in detections]
    t = np.concatenate(times) if detections else np.zeros(0)
    if frame == "zup":
        pts = np.column_stack([pts[:, 1], pts[:, 0], -pts[:, 2]])
    write_ply(path, pts, scalars={"object_id": ids, "time": t}, comment=ZUP_COMMENT if frame == "zup" else NED_COMMENT)


class DetectionStream:
    """Appends one detection at a time to ``DIR/detections.jsonl`` (and its PLY); see the module doc."""

    def __init__(self, out_dir: Path, ply_frame: str = "ned") -> None:
        self.out_dir = out_dir
        self.ply_frame = check_ply_frame(ply_frame)
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
            write_points_ply(path_inside(self.out_dir, name), [det], self.ply_frame)
            with open(self.path, "a") as f:
                f.write(json.dumps(to_jsonable(det.to_json(name)), allow_nan=False) + "\n")
                f.flush()
        except OSError as exc:  # the run goes on; write_outputs tries the whole folder again at the end
            self.error = exc
            return
        self.count += 1


def _write(out_dir: Path, name: str, write: Callable[[Path], Any], unwritten: list[str] | None) -> None:
    """Write ``out_dir/name`` atomically; with ``unwritten`` a failure is listed there instead of raised."""
    target = path_inside(out_dir, name)  # OutputError (never listed as unwritten): a name that leaves out_dir
    try:
        with atomic_path(target) as tmp:
            write(tmp)
    except OSError as exc:
        if unwritten is None:
            raise OutputError(f"cannot write {out_dir / name}: {exc.strerror or exc}") from exc
        unwritten.append(f"{name} ({exc.strerror or exc})")


def write_outputs(result: MissionResult, out_dir: Path, *, keep_going: bool = False,
                  ply_frame: str = "ned") -> dict[str, Any]:
    """Write the files of ARCHITECTURE.md's output folder; returns the summary dict. A file that cannot
    be written raises :class:`OutputError`; with ``keep_going`` (a live run: write what can be written)
    the others are still written and the summary lists the failed ones under ``unwritten``. PLY files
    in ``ply_frame`` (see the module docstring)."""
    check_ply_frame(ply_frame)
    unwritten: list[str] | None = [] if keep_going else None
    out_dir.mkdir(parents=True, exist_ok=True)
    obj_dir = out_dir / "objects"
    obj_dir.mkdir(exist_ok=True)
    lines = []
    for det in result.detections:
        name = object_ply_name(det)
        _write(out_dir, name, functools.partial(write_points_ply, detections=[det], frame=ply_frame), unwritten)
        lines.append(json.dumps(to_jsonable(det.to_json(name)), allow_nan=False))
    _write(out_dir, "detections.jsonl", lambda p: p.write_text("".join(line + "\n" for line in lines)),
           unwritten)
    _write(out_dir, "cloud.ply", lambda p: write_points_ply(p, result.detections, ply_frame), unwritten)
    _write(out_dir, "results.mcap", lambda p: write_results_mcap(result, p), unwritten)
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
        "ply_frame": ply_frame,
        "results_mcap": {"fan_frames": len(result.fan_frames), "poses": int(result.poses.t.size)},
        "georef": {**result.georef, "files": gis_files},
    }
    if unwritten is not None:
        summary["unwritten"] = unwritten  # the summary itself last: what it says is all that failed before it
    text = json.dumps(to_jsonable(summary), indent=2, allow_nan=False) + "\n"
    _write(out_dir, "summary.json", lambda p: p.write_text(text), unwritten)
    return summary
