"""Recon against the simulator's ground truth, in process (evaluation only: tests and benchmarks).

:func:`simulate` renders every sonar frame of a scene's survey with :mod:`auvlink.sim` (the same
renderer, poses and per-frame seeds as ``auvlink sim``; no log, no wire) and returns them with the
true trajectory. :func:`evaluate` runs :class:`recon.reconstructor.Reconstructor` on them
(:func:`reconstruct`) with the true navigation and scores the objects against the truth
(:func:`match`): each true object is matched to the clusters whose centroid lies within ``radius`` m
horizontally and nearer to it than to any other object (0 = missed or merged into a neighbour,
2+ = split; :func:`cluster_errors` counts splits, merges, misses and spurious clusters), centroid
errors are horizontal distances to the object's position (the scene's north/east), and point
accuracy is the distance of every object point to the true mesh
surface (Open3D ``RaycastingScene.compute_distance``). It sits in the application layer: it drives
the simulator, the pipeline's navigation and the log, which ``recon`` itself never imports.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import open3d as o3d
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from auvlink.pipeline.collect import MissionData
from auvlink.pipeline.setup import MissionSetup, nav_config
from auvlink.sim.mission import prepare, simulate_to_log, truth_pose
from auvlink.sim.object_meshes import placed_mesh
from auvlink.sim.scene import Scene
from auvlink.sim.sonar_render import SonarRenderer
from auvlink.sim.truth import TRAJECTORY_ATTACHMENT
from logs_format import MissionLogReader, Replay
from recon.cluster import DetectedObject, robust_centre
from recon.nav import dead_reckon
from recon.reconstructor import ReconConfig, Reconstructor
from recon.sonar_geometry import SonarGeometry
from recon.trajectory import Trajectory

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class SimFrames:
    """A rendered survey: frame times (s), images (F, range bins, beams), the true trajectory, the geometry."""

    scene: Scene
    times: F64
    images: NDArray[np.uint8]
    trajectory: Trajectory
    geometry: SonarGeometry
    truth_xy: F64  # (objects, 2) north, east of every scene object
    meshes: list[tuple[F64, NDArray[np.int32]]] = field(repr=False)


def simulate(scene: Scene, duration: float | None = None, speckle: bool = True) -> SimFrames:
    """Render every sonar frame of ``scene``'s survey (true poses, noise-free navigation)."""
    run = prepare(scene, duration=duration, noise=False)
    renderer = SonarRenderer(run.scene, speckle=speckle)
    s = run.measurements.sonar
    frames = renderer.render_sequence(s.position, Rotation.from_matrix(s.r_wb), run.scene.seed)
    fan = renderer.geometry
    images = np.stack(list(frames)) if len(s.t) else np.zeros((0, fan.n_bins, fan.n_beams), np.uint8)
    pose = truth_pose(run)
    traj = Trajectory.from_euler(pose.t, pose.position, pose.yaw, pose.pitch, pose.roll, altitude=pose.altitude)
    sc = run.scene.sonar
    d = sc.description  # the renderer's beams and range bins; a linear fan by its field, an uneven one by its table
    geom = SonarGeometry.from_degrees(sc.tilt_deg, sc.spread_deg, window_start=sc.window_start,
                                      window_length=sc.window_length, lever_arm=tuple(sc.lever_arm),
                                      n_bins=fan.n_bins, n_beams=fan.n_beams,
                                      fov=float(np.deg2rad(d.field_of_view_deg)),
                                      azimuth_table=None if d.is_linear else d.bearings_rad)
    truth = np.array([[o.north, o.east] for o in run.scene.objects]).reshape(-1, 2)
    meshes = [placed_mesh(o, renderer.seabed) for o in run.scene.objects]
    inside = (s.t >= traj.span[0]) & (s.t <= traj.span[1])
    return SimFrames(run.scene, np.asarray(s.t[inside], np.float64), images[inside], traj, geom, truth, meshes)


def mesh_distance(points: F64, meshes: list[tuple[F64, NDArray[np.int32]]]) -> F64:
    """Unsigned distance (m) of each point to the nearest triangle of ``meshes``."""

    p = np.asarray(points, np.float64).reshape(-1, 3)
    if p.shape[0] == 0 or not meshes:
        return np.full(p.shape[0], np.inf)
    origin = p.mean(axis=0)  # Open3D works in float32: measure near the points
    rs = o3d.t.geometry.RaycastingScene()
    for v, f in meshes:
        rs.add_triangles(o3d.core.Tensor.from_numpy(np.ascontiguousarray(v - origin, np.float32)),
                         o3d.core.Tensor.from_numpy(np.ascontiguousarray(f, np.uint32)))
    q = o3d.core.Tensor.from_numpy(np.ascontiguousarray(p - origin, np.float32))
    return np.asarray(rs.compute_distance(q).numpy(), np.float64)


@dataclass(frozen=True, eq=False)
class Evaluation:
    objects: list[DetectedObject]
    matches: list[list[int]]  # per true object, the indices of the clusters matched to it
    centroid_error: F64  # per true object: horizontal error of its (single or merged) cluster, NaN if missed
    distances: F64  # every object point's distance to the nearest true mesh
    recon: Reconstructor

    @property
    def exactly_one(self) -> bool:
        """Every true object is exactly one cluster, and no cluster serves two objects."""
        used = [j for m in self.matches for j in m]
        return all(len(m) == 1 for m in self.matches) and len(used) == len(set(used))

    def summary(self) -> dict[str, Any]:
        d = self.distances
        ok = np.isfinite(self.centroid_error)
        return {"objects": len(self.objects), "clusters_per_truth": [len(m) for m in self.matches],
                "exactly_one": self.exactly_one,
                "centroid_error_mean_m": float(self.centroid_error[ok].mean()) if ok.any() else None,
                "centroid_error_max_m": float(self.centroid_error[ok].max()) if ok.any() else None,
                "points": int(d.size), "mean_m": float(d.mean()) if d.size else None,
                "p95_m": float(np.percentile(d, 95)) if d.size else None}


def reconstruct(frames: SimFrames, config: ReconConfig | None = None, block: int = 64,
                trajectory: Trajectory | None = None) -> tuple[Reconstructor, list[DetectedObject]]:
    """Recon on ``frames`` in blocks of ``block`` (true navigation unless ``trajectory`` is given)."""
    rec = Reconstructor(frames.geometry, trajectory or frames.trajectory, config)
    for k in range(0, frames.times.size, block):
        rec.add_frames(frames.times[k : k + block], frames.images[k : k + block])
    return rec, rec.finish()


def object_points(frames: SimFrames, config: ReconConfig | None = None, block: int = 64) -> tuple[F64, F64, F64]:
    """The points (after seabed removal) that :meth:`Reconstructor.finish` would cluster, with their times
    and extra columns: the input of the clustering knobs (eps, voxel size) in the benchmark."""
    rec = Reconstructor(frames.geometry, frames.trajectory, config)
    for k in range(0, frames.times.size, block):
        rec.add_frames(frames.times[k : k + block], frames.images[k : k + block])
    return rec.take_pending_points()


def match(objects: list[DetectedObject], truth_xy: F64, radius: float = 1.5) -> list[list[int]]:
    """Per true object, the clusters whose centroid lies within ``radius`` m of it horizontally and
    nearer to it than to any other true object (0 = missed, 2+ = split)."""
    cen = np.array([o.centroid[:2] for o in objects]).reshape(-1, 2)
    dist = np.linalg.norm(cen[None, :, :] - truth_xy[:, None, :], axis=2)  # (truth, clusters)
    owner = np.argmin(dist, axis=0) if len(objects) else np.zeros(0, np.int64)
    return [[j for j in range(len(objects)) if dist[i, j] <= radius and owner[j] == i]
            for i in range(truth_xy.shape[0])]


def cluster_errors(objects: list[DetectedObject], truth_xy: F64, radius: float = 1.5) -> dict[str, int]:
    """Counts against the truth, each true object counted once: ``splits`` (clusters beyond the first of
    an object), ``merges`` (objects without a cluster of their own while another object's cluster has
    points within ``radius / 2`` of them), ``missed`` (no cluster at all), and ``spurious`` clusters
    (matched to no object); ``wrong`` is their sum (0: every object exactly one cluster)."""
    m = match(objects, truth_xy, radius)
    used = {j for js in m for j in js}
    merges = missed = 0
    for i, js in enumerate(m):
        if js:
            continue
        near = any(np.linalg.norm(o.points[:, :2] - truth_xy[i], axis=1).min() <= 0.5 * radius for o in objects)
        merges += int(near)
        missed += int(not near)
    splits = sum(max(0, len(js) - 1) for js in m)
    spurious = sum(j not in used for j in range(len(objects)))
    return {"splits": splits, "merges": merges, "missed": missed, "spurious": spurious,
            "wrong": splits + merges + missed + spurious}


def evaluate(frames: SimFrames, config: ReconConfig | None = None, radius: float = 1.5, block: int = 64,
             trajectory: Trajectory | None = None) -> Evaluation:
    """Recon on ``frames`` (true navigation unless ``trajectory`` is given), scored against the truth."""
    rec, objs = reconstruct(frames, config, block, trajectory)
    matches = match(objs, frames.truth_xy, radius)
    err = np.full(frames.truth_xy.shape[0], np.nan)
    for i, m in enumerate(matches):
        if m:
            c = objs[m[0]].centroid if len(m) == 1 else robust_centre(np.concatenate([objs[j].points for j in m]))
            err[i] = float(np.linalg.norm(c[:2] - frames.truth_xy[i]))
    pts = np.concatenate([o.points for o in objs]) if objs else np.zeros((0, 3))
    return Evaluation(objs, matches, err, mesh_distance(pts, frames.meshes), rec)


def nav_drift(scene: Scene, workdir: str, duration: float | None = None, noise: bool | None = None
              ) -> dict[str, Any]:
    """Dead-reckoning error against the truth on a simulated log (``noise``: None = the scene's).

    The mission is simulated into ``workdir``/nav.mcap and replayed through the pipeline's navigation
    (framers, codecs, :func:`recon.nav.dead_reckon`); errors are horizontal, against the log's true
    trajectory attachment, and drift is given as a fraction of the distance travelled.
    """
    log = Path(workdir) / "nav.mcap"
    simulate_to_log(scene, log, progress=False, duration=duration, workers=1, noise=noise)
    with MissionLogReader(log) as reader:
        setup = MissionSetup.from_metadata(reader.metadata(decode_json=True))
        truth = np.load(io.BytesIO(reader.read_attachment(TRAJECTORY_ATTACHMENT)))
    data = MissionData()
    with Replay(log) as replay:
        for sample in replay.samples():
            if sample.device != "sonar":
                data.add(sample)
    log.unlink()
    traj = dead_reckon(*data.nav_inputs(), nav_config(setup))
    t_truth = (truth["t_ns"] - (data.t0_ns or 0)) * 1e-9
    lo, hi = max(traj.span[0], t_truth[0]), min(traj.span[1], t_truth[-1])
    t = np.linspace(lo, hi, 2000)
    est = traj.pose_at(t)[0]
    tru = np.column_stack([np.interp(t, t_truth, truth[k]) for k in ("north", "east", "down")])
    err = np.linalg.norm(est[:, :2] - tru[:, :2], axis=1)
    dist = float(np.linalg.norm(np.diff(tru[:, :2], axis=0), axis=1).sum())
    return {"distance_m": dist, "duration_s": float(hi - lo), "max_horizontal_error_m": float(err.max()),
            "final_horizontal_error_m": float(err[-1]), "max_error_over_distance": float(err.max()) / dist,
            "max_depth_error_m": float(np.abs(est[:, 2] - tru[:, 2]).max())}
