"""Run the pipeline on a mission log: replay -> the streaming engine -> detections; the result types.

Replay goes through :class:`logs_format.Replay`, i.e. the same decoders (framer + codec) as live
operation, for the channels whose wire format a stage consumes
(:data:`auvlink.pipeline.nav_inputs.CONSUMED_FORMATS`; the others are counted, not decoded), and
the samples through :class:`auvlink.pipeline.engine.Engine`, the engine of ``auvlink live``. Each
stage is timed; the result carries everything the outputs and the report need. :func:`run_log_batch`
keeps the non-causal batch path as a reference for tests.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from auvlink.errors import AuvlinkError
from auvlink.pipeline.nav_inputs import CONSUMED_FORMATS
from auvlink.pipeline.setup import MissionSetup, nav_config, sonar_geometry

FRAME_BLOCK = 64  # frames per reconstruction call when replaying a log not recorded live


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


@dataclass(frozen=True)
class StripFrame:
    """A sonar frame kept for the report, with the pose it was processed with (mission time s)."""

    t: float
    image: np.ndarray
    position: np.ndarray  # (1, 3)
    rotation: Any  # scipy Rotation (1)
    altitude: np.ndarray  # (1,)


@dataclass
class MissionResult:
    """Everything a run produced (live or replay)."""

    log: Path | None
    setup: MissionSetup
    detections: list[Detection]
    track: np.ndarray  # (n, 3) vehicle positions, world NED
    t0: float = 0.0  # s since the epoch of mission time 0
    strip: list[StripFrame] = field(default_factory=list)
    geometry: Any = None  # recon.sonar_geometry.SonarGeometry of the sonar, when it had frames
    timings: dict[str, float] = field(default_factory=dict)
    latency: dict[str, dict[str, Any]] = field(default_factory=dict)
    replay_stats: dict[str, Any] = field(default_factory=dict)
    recon_stats: dict[str, Any] = field(default_factory=dict)
    loss: str = ""
    highlight_points: np.ndarray | None = None
    drops: dict[str, int] = field(default_factory=dict)
    events: list[dict[str, Any]] = field(default_factory=list)
    mode: str = "replay"
    engine: dict[str, Any] = field(default_factory=dict)


def live_settings(meta: dict[str, dict[str, Any]]) -> tuple[dict[str, Any], int | None]:
    """The engine settings and time origin a live run stored in its log (empty, None otherwise)."""
    rec = meta.get(LIVE_META) or {}
    engine = rec.get("engine") if isinstance(rec.get("engine"), dict) else {}
    t0 = rec.get("t0_ns")
    return dict(engine or {}), (int(t0) if t0 is not None else None)


LIVE_META = "live_pipeline"


def run_log(log: Path, *, speed: float | None = None, model: Path | None = None, classify: bool = True,
            progress: bool = True, recon_config: Any = None, engine_config: Any = None,
            on_detection: Any = None) -> MissionResult:
    """The streaming engine on a log (``auvlink replay``): the same engine as ``auvlink live``.

    A log written by ``auvlink live`` carries the live engine settings and time origin; they are
    used unless ``engine_config`` is given, so the replay gives the live detections.
    """
    from auvlink.pipeline.engine import Engine, EngineConfig
    from logs_format import MissionLogReader, Replay

    t_start = time.perf_counter()
    with MissionLogReader(log) as reader:
        meta = reader.metadata(decode_json=True)
        duration = reader.duration_s
        log_start = reader.start_ns
        dropped = dropped_live(reader)
    setup = MissionSetup.from_metadata(meta)
    live_cfg, t0_ns = live_settings(meta)
    cfg = engine_config or (EngineConfig.from_dict(live_cfg) if live_cfg else EngineConfig(frame_block=FRAME_BLOCK))
    engine = Engine(setup, cfg, t0_ns=t0_ns, recon_config=recon_config, classify=classify, model=model,
                    on_detection=on_detection)
    t_warm = time.perf_counter()
    engine.warm_up()
    warm_s = time.perf_counter() - t_warm
    replay = Replay(log, speed=speed, formats=CONSUMED_FORMATS)
    bar = tqdm(total=round(duration or 0.0, 1), unit="s", desc="replay", disable=not progress,
               leave=False, bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} s mission [{elapsed}]")
    last_adv = None
    shown = 0.0
    decode_s = 0.0
    skipped: dict[str, int] = {}
    index: dict[str, int] = {}  # per device: the sample's ordinal, as live counted it
    t_read = time.perf_counter()
    with replay:
        for sample in replay.samples():
            t_ns = sample.t_host_ns
            if dropped:
                k = index.get(sample.device, 0)
                index[sample.device] = k + 1
                if (sample.device, k) in dropped or (sample.device, -1, t_ns) in dropped:  # live never had it
                    skipped[sample.device] = skipped.get(sample.device, 0) + 1
                    continue
            engine.feed(sample)
            if last_adv is None:
                last_adv = t_ns
            elif t_ns - last_adv >= ADVANCE_NS:
                decode_s += time.perf_counter() - t_read
                engine.advance(t_ns)
                last_adv = t_ns
                t_read = time.perf_counter()
                t = min((t_ns - (log_start or t_ns)) * 1e-9, bar.total or 0.0)
                if t - shown >= 1.0:
                    bar.update(t - shown)
                    shown = t
        decode_s += time.perf_counter() - t_read
        engine.finish()
        stats = replay.stats()
        loss = str(getattr(replay, "loss", "") or "")
    bar.close()
    timings = {"start_up_s": warm_s, "replay_decode_s": decode_s, "navigation_s": engine.times.total("navigation"),
               "reconstruction_s": engine.times.total("reconstruction"),
               "clustering_s": engine.times.total("clustering"),
               "classification_s": engine.times.total("classification"),
               "total_s": time.perf_counter() - t_start}
    return result_of(engine, log, timings, stats, loss, mode="replay", drops=skipped)


def dropped_live(reader: Any) -> set[tuple[Any, ...]]:
    """The frames a live run dropped (its ``events`` channel): ``(device, sample ordinal in that device's
    stream)``; ``(device, -1, receive time ns)`` for events without the ordinal (logs of earlier versions:
    frames read together share that time, so these may skip a frame live kept)."""
    import json

    if "events" not in reader.channels:
        return set()
    out: set[tuple[Any, ...]] = set()
    for msg in reader.messages(channels=["events"]):
        try:
            ev = json.loads(msg.data)
        except ValueError:
            continue
        if ev.get("kind") != "frame_dropped":
            continue
        if "sample_index" in ev:
            out.add((str(ev["device"]), int(ev["sample_index"])))
        elif "frame_t_ns" in ev:
            out.add((str(ev["device"]), -1, int(ev["frame_t_ns"])))
    return out


ADVANCE_NS = 4_000_000_000  # replay hands samples to the engine in 4 s blocks (results do not depend on it)


def result_of(engine: Any, log: Path | None, timings: dict[str, float], stats: dict[str, Any], loss: str,
              mode: str, drops: dict[str, int] | None = None, events: list[dict[str, Any]] | None = None
              ) -> MissionResult:
    return MissionResult(log=log, setup=engine.setup, detections=engine.detections, track=engine.track(),
                         t0=(engine.t0_ns or 0) * 1e-9, strip=engine.strip, geometry=engine.geometry,
                         timings=timings, latency=engine.times.summary(), replay_stats=stats,
                         recon_stats=engine.recon_stats(), loss=loss, highlight_points=engine.highlight_points(),
                         drops=dict(drops or {}), events=list(events or []), mode=mode,
                         engine=engine.config.to_dict())


def run_log_batch(log: Path, *, recon_config: Any = None) -> tuple[list[Any], Any]:
    """Reference for tests: the whole mission dead-reckoned at once (non-causal), reconstructed in
    blocks and clustered at the end; returns (objects, trajectory). No classification."""
    from auvlink.pipeline.collect import MissionData
    from logs_format import MissionLogReader, Replay
    from recon.nav import dead_reckon
    from recon.pipeline import Reconstructor

    with MissionLogReader(log) as reader:
        setup = MissionSetup.from_metadata(reader.metadata(decode_json=True))
    data = MissionData()
    with Replay(log, formats=CONSUMED_FORMATS) as replay:
        for sample in replay.samples():
            data.add(sample)
    if data.n("dvl") < 2 or data.n("gyro") < 2 or not data.n("depth"):
        raise AuvlinkError(f"{log}: not enough navigation to process")
    traj = dead_reckon(*data.nav_inputs(), nav_config(setup))
    times, images = data.sonar.stack()
    rec = Reconstructor(sonar_geometry(setup, data.sonar.azimuths, data.sonar.window), traj,
                        recon_config or default_recon_config())
    lo, hi = traj.span
    idx = np.flatnonzero((times >= lo) & (times <= hi))
    for k in range(0, idx.size, FRAME_BLOCK):
        sel = idx[k : k + FRAME_BLOCK]
        rec.add_frames(times[sel], images[sel])
    return rec.finish(), traj
