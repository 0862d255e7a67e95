"""Simulate a whole mission into an MCAP mission log, as fast as the machine allows.

    result = simulate_to_log(load_default_scene(), "mission.mcap")

The run is cut into blocks of mission time; each block's events (every raw frame of every
device, :func:`auvlink.sim.emit.block_events`) are computed by a pool of worker processes
(rendering the sonar is the cost) and written in order by this process into one
:class:`~logs_format.writer.MissionLogWriter`: one channel per device, log time = mission start
(:attr:`SensorSettings.start`, 2026-01-01T00:00:00Z by default) + t, publish time = the sensor's
own clock where the format has one. A JSON channel ``truth/pose`` (``foxglove.PoseInFrame``)
carries the true pose at ``truth_topic_hz`` (10 Hz: each JSON message costs the writer as much as
a raw frame; the full-rate truth, ``truth_hz`` = 50 Hz, is the ``truth/trajectory.npy`` attachment);
the ``vehicle_config``, ``software`` and ``ground_truth`` metadata and the attachments of
:mod:`auvlink.sim.truth` come first.

Determinism: the same scene, seed and settings give the same file, byte for byte, whatever the
number of workers or the block length: every draw comes from a seeded stream, every frame's bytes
depend only on its own index, and the writer runs without time-based chunk flushes, without the
host's platform string and with fixed attachment times. At most ``2 x workers + 1`` blocks are in
flight, so memory stays bounded however long the mission.
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing as mp
import os
import sys
import time
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from multiprocessing.pool import AsyncResult, Pool
from pathlib import Path
from typing import Any

import numpy as np

from auvlink.progress import progress_bar
from auvlink.sim.aris_frame import aris_scene
from auvlink.sim.emit import Event, block_events, device_formats, sonar_format
from auvlink.sim.noise import NoiseConfig, SimError
from auvlink.sim.scene import MAX_MISSION_S, MAX_SEED, Scene
from auvlink.sim.sensors import Measurements, measure, sample_times
from auvlink.sim.settings import SimSettings, check_budget, settings_for
from auvlink.sim.sonar_render import SonarRenderer
from auvlink.sim.trajectory import LawnmowerTrajectory, TruePose
from auvlink.sim.truth import POSE_TOPIC, ground_truth, vehicle_config
from auvlink.version import __version__
from logs_format.profile import META_GROUND_TRUTH, META_SOFTWARE
from logs_format.schemas import POSE_SCHEMA, POSE_SCHEMA_NAME, pose_message
from logs_format.writer import MissionLogWriter

BLOCK_S = 4.0
#: below this many sonar frames a pool costs more than it saves
POOL_MIN_FRAMES = 400


@dataclass
class SimResult:
    path: Path
    duration_s: float  # mission time simulated
    wall_s: float  # seconds it took
    frames: dict[str, int] = field(default_factory=dict)  # raw frames per device
    workers: int = 1

    @property
    def sonar_fps(self) -> float:
        """Sonar frames simulated (rendered, encoded, logged) per second of wall time."""
        return self.frames.get("sonar", 0) / self.wall_s if self.wall_s > 0 else math.inf


@dataclass(frozen=True)
class Run:
    """A prepared run: the scene (seed applied), settings, the trajectory and every measurement."""

    scene: Scene
    settings: SimSettings
    trajectory: LawnmowerTrajectory
    measurements: Measurements

    @property
    def duration(self) -> float:
        return self.measurements.duration


def prepare(scene: Scene, seed: int | None = None, duration: float | None = None, *,
            settings: SimSettings | None = None, noise: bool | NoiseConfig | None = None) -> Run:
    """Apply the seed and noise overrides and compute every measurement of the run.

    ``seed`` replaces the scene's seed (it seeds every draw, the seabed and the oscillations too);
    ``noise=False`` gives the noise-free mode, a :class:`NoiseConfig` replaces the scene's. An ARIS' window
    becomes the one it samples in whole microseconds at the settings' sound speed
    (:func:`auvlink.sim.aris_frame.aris_scene`): the run's scene is what its frames say.
    """
    if seed is not None:
        if not 0 <= seed <= MAX_SEED:
            raise SimError(f"the seed must be in [0, {MAX_SEED}] (a scene's seed), got {seed}")
        scene = replace(scene, seed=seed)
    settings = settings_for(scene) if settings is None else settings
    if noise is not None:
        settings = replace(settings, noise=noise if isinstance(noise, NoiseConfig) else
                           (NoiseConfig() if noise else NoiseConfig.off()))
    if duration is not None and not (math.isfinite(duration) and 0 < duration <= MAX_MISSION_S):
        raise SimError(f"the duration must be a number of seconds in (0, {MAX_MISSION_S:.0f}] (12 h, a scene's "
                       f"longest mission), got {duration}")
    check_budget(scene, settings)
    scene = aris_scene(scene, settings.sensors.sound_speed)
    traj = LawnmowerTrajectory.from_scene(scene)
    return Run(scene, settings, traj, measure(scene, settings, duration, traj))


def surface_phases(traj: LawnmowerTrajectory) -> dict[str, float] | None:
    """Mission times (s) of the surface phases: dive, survey start, climb, surfaced, end (None without)."""
    sp = traj.surface
    if sp is None:
        return None
    return {"t_dive_s": sp.t_wait0, "t_survey_s": sp.t_survey, "t_climb_s": sp.t_climb0,
            "t_surfaced_s": sp.t_surfaced, "t_end_s": sp.t_end}


def truth_pose(run: Run) -> TruePose:
    return run.trajectory.true_pose(sample_times(run.settings.sensors.truth_hz, run.duration))


# --- workers ----------------------------------------------------------------------------------------
_STATE: dict[str, Any] = {}


def _init_worker(scene: Scene, m: Measurements) -> None:
    _STATE["m"], _STATE["renderer"] = m, SonarRenderer(scene)


def _work(t0: float, t1: float) -> list[Event]:
    return block_events(_STATE["m"], t0, t1, _STATE["renderer"])


def _blocks(run: Run, block_s: float) -> list[tuple[float, float]]:
    last = run.duration + run.settings.sensors.keller_latency_s  # the last Keller answer comes after
    n = math.floor(last / block_s) + 1
    return [(b * block_s, (b + 1) * block_s) for b in range(n)]


def worker_pool(run: Run, workers: int) -> Pool:
    """A pool of ``workers`` processes that render and encode blocks of ``run`` (fork where there is one)."""
    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else None)
    return ctx.Pool(workers, initializer=_init_worker, initargs=(run.scene, run.measurements))


def iter_blocks(run: Run, block_s: float = BLOCK_S, pool: Pool | None = None,
                workers: int = 2) -> Iterator[list[Event]]:
    """The events of the run, block by block in time order: here, or on ``pool`` (of ``workers``)."""
    blocks = _blocks(run, block_s)
    if pool is None:
        _init_worker(run.scene, run.measurements)
        try:
            for t0, t1 in blocks:
                yield _work(t0, t1)
        finally:
            _STATE.clear()
        return
    pending: deque[AsyncResult[list[Event]]] = deque()
    todo = iter(blocks)
    for t0, t1 in todo:
        pending.append(pool.apply_async(_work, (t0, t1)))
        if len(pending) > 2 * workers:
            break
    while pending:
        events = pending.popleft().get()
        nxt = next(todo, None)
        if nxt is not None:
            pending.append(pool.apply_async(_work, nxt))
        yield events


#: most worker processes: 16 x the 16-core machines the benchmarks ran on (each holds the scene and measurements)
MAX_WORKERS = 256


def default_workers(run: Run) -> int:
    frames = len(run.measurements.sonar.t)
    return 1 if frames < POOL_MIN_FRAMES else max(1, min(2, os.cpu_count() or 1))


def simulate_to_log(scene: Scene, out_path: str | Path, seed: int | None = None, progress: bool = True,
                    duration: float | None = None, *, noise: bool | NoiseConfig | None = None,
                    settings: SimSettings | None = None, workers: int | None = None,
                    block_s: float = BLOCK_S) -> SimResult:
    """Simulate the scene's survey into the mission log ``out_path`` (see the module docstring)."""
    t_wall = time.perf_counter()
    run = prepare(scene, seed, duration, settings=settings, noise=noise)
    if workers is not None and not 1 <= workers <= MAX_WORKERS:
        raise SimError(f"the number of workers must be in [1, {MAX_WORKERS}], got {workers}")
    n_workers = default_workers(run) if workers is None else workers
    formats = device_formats(run.measurements, sonar_format(run.scene.sonar))
    start = run.settings.sensors.start_ns
    meta, attachments = ground_truth(run.scene, run.settings, run.duration, truth_pose(run), formats,
                                     surface_phases(run.trajectory))
    topic_hz = run.settings.sensors.truth_topic_hz
    topic_t = sample_times(topic_hz, run.duration) if topic_hz > 0 else np.zeros(0)
    truth_ns = [start + round(t * 1e9) for t in topic_t.tolist()]
    positions, quats = np.zeros((0, 3)), np.zeros((0, 4))
    if len(topic_t):
        pose = run.trajectory.true_pose(topic_t)
        positions, quats = pose.position, pose.rotation().as_quat()
    out = Path(out_path)
    j = 0  # next truth pose
    with contextlib.ExitStack() as stack:  # the pool forks before any thread (tqdm's monitor) starts
        pool = stack.enter_context(worker_pool(run, n_workers)) if n_workers > 1 else None
        bar = stack.enter_context(progress_bar(total=len(run.measurements.sonar.t), enabled=progress,
                                               unit="frame", desc="auvlink sim", file=sys.stderr,
                                               dynamic_ncols=True))
        log = stack.enter_context(MissionLogWriter(out, flush_interval=0.0, fsync=False, software=False,
                                                   keep_failed=False))  # a failed run leaves ``out`` as it was
        log.add_metadata(META_SOFTWARE, {"name": "auvlink", "version": __version__, "generator": "auvlink.sim"})
        log.add_vehicle_config(vehicle_config(run.scene, run.settings))
        log.add_metadata(META_GROUND_TRUTH, meta)
        for name, blob in attachments.items():
            media = "model/ply" if name.endswith(".ply") else "application/x-npy"
            log.add_attachment(name, blob, media, log_time_ns=start, create_time_ns=start)
        for events in iter_blocks(run, block_s, pool, n_workers):
            sonar = 0
            for t_ns, _, _, device, raw, t_sensor in events:
                while j < len(truth_ns) and truth_ns[j] <= t_ns:
                    log.add_json(POSE_TOPIC, POSE_SCHEMA_NAME, POSE_SCHEMA, truth_ns[j],
                                 pose_message(truth_ns[j], positions[j], quats[j]))
                    j += 1
                log(device, formats[device], t_ns, raw, t_sensor)
                sonar += device == "sonar"
            bar.update(sonar)
        if pool is not None:
            pool.close()  # every block is in: the workers end on their own (the context's exit would terminate them)
            pool.join()
        while j < len(truth_ns):
            log.add_json(POSE_TOPIC, POSE_SCHEMA_NAME, POSE_SCHEMA, truth_ns[j],
                         pose_message(truth_ns[j], positions[j], quats[j]))
            j += 1
        counts = log.counts()
    frames = {d: counts.get(d, 0) for d in formats}
    return SimResult(out, run.duration, time.perf_counter() - t_wall, frames, n_workers)
