"""Survey frames for the simulator benchmarks (:mod:`bench_sim`, :mod:`_sim_models`) and their frames/s."""

from __future__ import annotations

import time

import numpy as np
from _common import best_time
from scipy.spatial.transform import Rotation

from auvlink.sim.scene import Scene
from auvlink.sim.sonar_render import MISS, OBJECT, SonarRenderer
from auvlink.sim.trajectory import LawnmowerTrajectory


def frames_of(scene: Scene, n: int, stride: int = 1) -> dict[str, tuple[np.ndarray, Rotation]]:
    """Poses of up to ``n`` survey frames with an object in view (a return inside the range window), and ``n``
    that see only the seabed in the window (every ``stride``-th frame of the survey probed)."""
    tr = LawnmowerTrajectory.from_scene(scene)
    pose = tr.true_pose(np.arange(0.0, tr.duration, stride / scene.sonar.fps))
    probe = SonarRenderer(scene, cull="none", speckle=False)
    mats = pose.rotation().as_matrix()
    end = scene.sonar.window_start + scene.sonar.window_length

    def in_window(p: np.ndarray, m: np.ndarray) -> tuple[bool, bool]:  # an object, anything, in the window
        h = probe.trace_matrix(p, m)
        lit = (h.kind != MISS) & (h.range < end)
        return bool((lit & (h.kind == OBJECT)).any()), bool(lit.any())

    seen, lit = np.array([in_window(p, m) for p, m in zip(pose.position, mats, strict=True)]).T
    out = {}
    for name, mask in (("objects in view", seen), ("seabed only", lit & ~seen)):
        idx = np.flatnonzero(mask)[:n]
        out[name] = (pose.position[idx], Rotation.from_matrix(mats[idx]))
    return out


def fps(rd: SonarRenderer, frames: tuple[np.ndarray, Rotation], repeat: int) -> float:
    """Frames/s, wall clock, best of ``repeat`` passes."""
    pos, rot = frames
    t = best_time(lambda: sum(1 for _ in rd.render_sequence(pos, rot, seed=1)), repeat)
    return len(pos) / t


def fps_cpu(rd: SonarRenderer, frames: tuple[np.ndarray, Rotation], repeat: int) -> float:
    """Frames/s of process CPU time (all threads), best of ``repeat`` passes: what the machine could
    do if this process had its cores to itself (other jobs share them while the benchmark runs)."""
    pos, rot = frames
    best = float("inf")
    for _ in range(max(1, repeat)):
        c0 = time.process_time()
        sum(1 for _ in rd.render_sequence(pos, rot, seed=1))
        best = min(best, time.process_time() - c0)
    return len(pos) / best
