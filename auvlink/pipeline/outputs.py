"""Write a run's outputs: ``detections.jsonl``, ``cloud.ply``, one PLY per object, ``summary.json``.

:class:`DetectionStream` writes each detection as it is made (its PLY, then its line, flushed), so a
live run's folder holds every object finalized so far even if the run is killed; :func:`write_outputs`
writes the whole folder at the end.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from auvlink.jsonutil import to_jsonable
from auvlink.pipeline.process import Detection, MissionResult
from auvlink.pipeline.scoring import score_detections


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

    def __call__(self, det: Detection) -> None:
        from recon.ply import write_ply

        name = object_ply_name(det)
        write_ply(self.out_dir / name, det.points)
        with open(self.path, "a") as f:
            f.write(json.dumps(to_jsonable(det.to_json(name)), allow_nan=False) + "\n")
            f.flush()
        self.count += 1


def write_outputs(result: MissionResult, out_dir: Path) -> dict[str, Any]:
    """Write the files of ARCHITECTURE.md's output folder; returns the summary dict."""
    from recon.ply import write_ply

    out_dir.mkdir(parents=True, exist_ok=True)
    obj_dir = out_dir / "objects"
    obj_dir.mkdir(exist_ok=True)
    lines = []
    for det in result.detections:
        name = object_ply_name(det)
        write_ply(out_dir / name, det.points)
        lines.append(json.dumps(to_jsonable(det.to_json(name)), allow_nan=False))
    (out_dir / "detections.jsonl").write_text("".join(line + "\n" for line in lines))
    cloud = (np.concatenate([d.points for d in result.detections]) if result.detections
             else np.zeros((0, 3)))
    write_ply(out_dir / "cloud.ply", cloud)
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
    }
    (out_dir / "summary.json").write_text(json.dumps(to_jsonable(summary), indent=2, allow_nan=False) + "\n")
    return summary
