"""Run the pipeline on a mission log: replay -> navigation -> reconstruction -> clusters -> classes.

Replay goes through :class:`logs_format.Replay`, i.e. the same framers, codecs and driver code
as live operation. Each stage is timed; the result carries everything the outputs and the report
need.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from auvlink.errors import AuvlinkError
from auvlink.pipeline.collect import MissionData
from auvlink.pipeline.setup import MissionSetup, nav_config, sonar_geometry

FRAME_BLOCK = 64


def default_recon_config() -> Any:
    """The pipeline's reconstruction settings, chosen on simulated missions (see benchmarks/RESULTS.md).

    Highlight threshold median + 4 MADs (the simulator's log-compressed frames: speckle up to ~85 grey
    levels, objects 140-190; the k = 8 default of recon missed the box). Front-slope correction on
    (arc re-placement): mean point-to-mesh distance 0.18 -> 0.03 m on the demo scene with true
    navigation. DBSCAN eps 0.5 m keeps each reef, whose frames and openings leave gaps of 0.3-0.5 m,
    in one cluster.
    """
    from recon.cluster import ClusterConfig
    from recon.highlight import HighlightConfig
    from recon.pipeline import ReconConfig

    return ReconConfig(highlight=HighlightConfig(k=4.0), front_slope=True, front_slope_method="arc",
                       cluster=ClusterConfig(eps=0.5))


@dataclass
class Detection:
    """One classified object (world frame NED, m; times s since the UNIX epoch)."""

    id: int
    class_name: str
    score: float
    position_ned: tuple[float, float, float]
    size: tuple[float, float, float]
    n_points: int
    t_first: float
    t_last: float
    points: np.ndarray

    def to_json(self, cloud: str) -> dict[str, Any]:
        return {"id": self.id, "class": self.class_name, "score": round(self.score, 4),
                "position_ned": [round(v, 4) for v in self.position_ned],
                "size": [round(v, 4) for v in self.size], "n_points": self.n_points,
                "t_first": self.t_first, "t_last": self.t_last, "cloud": cloud}


@dataclass
class MissionResult:
    """Everything a run produced."""

    log: Path
    setup: MissionSetup
    data: MissionData
    trajectory: Any
    detections: list[Detection]
    timings: dict[str, float] = field(default_factory=dict)
    replay_stats: dict[str, Any] = field(default_factory=dict)
    recon_stats: dict[str, Any] = field(default_factory=dict)
    loss: str = ""
    highlight_points: np.ndarray | None = None

    @property
    def t0(self) -> float:
        return (self.data.t0_ns or 0) * 1e-9


def _replay(log: Path, speed: float | None, progress: bool) -> tuple[MissionData, MissionSetup, dict[str, Any], str]:
    from logs_format import MissionLogReader, Replay

    with MissionLogReader(log) as reader:
        meta = reader.metadata(decode_json=True)
        duration = reader.duration_s
    setup = MissionSetup.from_metadata(meta)
    data = MissionData()
    replay = Replay(log, speed=speed)
    bar = tqdm(total=round(duration or 0.0, 1), unit="s", desc="replay", disable=not progress,
               leave=False, bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} s mission [{elapsed}]")
    last = 0.0
    for sample in replay.samples():
        data.add(sample)
        t = (sample.t_host_ns - (data.t0_ns or 0)) * 1e-9
        if t - last >= 1.0:
            bar.update(t - last)
            last = t
    bar.close()
    return data, setup, replay.stats(), str(getattr(replay, "loss", "") or "")


def run_log(log: Path, *, speed: float | None = None, model: Path | None = None, classify: bool = True,
            progress: bool = True, recon_config: Any = None) -> MissionResult:
    """The whole pipeline on one log (batch)."""
    from recon.nav import dead_reckon
    from recon.pipeline import Reconstructor

    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    data, setup, replay_stats, loss = _replay(log, speed, progress)
    timings["replay_decode_s"] = time.perf_counter() - t0
    if len(data.dvl_t) < 2 or len(data.gyro_t) < 2 or not data.depth_t:
        raise AuvlinkError(f"{log}: not enough navigation to process (DVL {len(data.dvl_t)}, gyro "
                           f"{len(data.gyro_t)}, pressure {len(data.depth_t)} samples)")
    t1 = time.perf_counter()
    traj = dead_reckon(*data.nav_inputs(), nav_config(setup))
    timings["navigation_s"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    times, images = data.sonar.stack()
    geometry = sonar_geometry(setup, data.sonar.azimuths, data.sonar.window)
    lo, hi = traj.span
    inside = (times >= lo) & (times <= hi)
    rec = Reconstructor(geometry, traj, recon_config or default_recon_config())
    idx = np.flatnonzero(inside)
    for k in tqdm(range(0, idx.size, FRAME_BLOCK), desc="recon", unit="block", disable=not progress, leave=False):
        sel = idx[k : k + FRAME_BLOCK]
        rec.add_frames(times[sel], images[sel])
    objects = rec.finish()
    timings["reconstruction_s"] = time.perf_counter() - t2
    t3 = time.perf_counter()
    labels: list[tuple[str, float]] = [("unknown", 0.0)] * len(objects)
    if classify and objects:
        from classify.infer import Classifier

        clf = Classifier.load(model)
        labels = clf.classify_many([o.points for o in objects])
    timings["classification_s"] = time.perf_counter() - t3
    epoch = (data.t0_ns or 0) * 1e-9
    dets = [
        Detection(id=i, class_name=c, score=float(s), position_ned=tuple(map(float, o.centroid)),  # type: ignore[arg-type]
                  size=tuple(map(float, o.size)), n_points=int(o.n_points),  # type: ignore[arg-type]
                  t_first=epoch + float(o.t_first), t_last=epoch + float(o.t_last), points=o.points)
        for i, (o, (c, s)) in enumerate(zip(objects, labels, strict=True))
    ]
    recon_stats = {"frames": rec.frames, "frames_in_nav_span": int(idx.size), "frames_total": int(times.size),
                   "frames_with_points": rec.frames_with_points, "points": rec.points_total,
                   "seabed_removed": rec.seabed_removed, "front_slope_removed": rec.front_slope_removed,
                   "objects": len(objects)}
    timings["total_s"] = time.perf_counter() - t0
    return MissionResult(log=log, setup=setup, data=data, trajectory=traj, detections=dets, timings=timings,
                         replay_stats=replay_stats, recon_stats=recon_stats, loss=loss,
                         highlight_points=rec.raw_points)
