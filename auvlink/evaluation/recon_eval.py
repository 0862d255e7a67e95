"""Clouds that recon reconstructs from simulated passes over single catalog objects (evaluation only).

Per pass: one object at the origin of a gently rough seabed, turned by ``heading``; the vehicle
flies a straight level line north at ``altitude`` and 1 m/s, ``lateral`` metres to the side, from
``run_in`` metres before the object to ``run_out`` past it. Frames are rendered by the simulator
(:class:`auvlink.sim.sonar_render.SonarRenderer`, speckle on) at ``fps`` and fed with the true poses
to :class:`recon.reconstructor.Reconstructor` with the pipeline's configuration
(:func:`auvlink.pipeline.engine.default_recon_config`), optionally overridden (highlight threshold
factor, front-slope carving). The cloud of the detected object nearest the origin is returned. Poses are
true here (no navigation noise); whole missions are the pipeline's test.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import math
import os
import zlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

import recon
from auvlink import sim
from auvlink.pipeline.engine_config import default_recon_config
from auvlink.progress import progress_bar
from auvlink.sim.acoustics import AcousticsTable, ProfileName
from auvlink.sim.scene import Scene, SceneObject, Seabed, SonarConfig, Survey
from auvlink.sim.sonar_render import SonarRenderer, frame_rng
from classify.infer import Classifier
from classify.training.evaluate import EvalReport
from recon.reconstructor import Reconstructor
from recon.sonar_geometry import SonarGeometry
from recon.trajectory import Trajectory


@dataclass(frozen=True)
class PassSettings:
    headings_deg: tuple[float, ...] = (10.0, 55.0, 100.0, 145.0, 190.0, 235.0, 280.0, 325.0)
    tilts_deg: tuple[float, ...] = (25.0, 35.0)
    altitudes_m: tuple[float, ...] = (4.5,)
    laterals_m: tuple[float, ...] = (0.0,)
    spread_deg: float = 14.0
    depth_m: float = 20.0
    roughness_m: float = 0.02
    window_start: float = 1.0
    window_length: float = 10.0
    fps: float = 10.0
    speed: float = 1.0
    run_in: float = 14.0
    run_out: float = 2.0
    rays_per_beam: int = 16
    seed: int = 7
    highlight_k: float | None = None  # override of recon's highlight threshold factor (None: its default)
    carve_front_slope: bool | None = None  # override of recon's front-slope carving (None: its default)
    acoustics: ProfileName = "ideal"  # the sonar profile the frames are rendered with (auvlink.sim.acoustics.PROFILES)
    calibrate: bool | None = None  # override of recon's calibration from the frames (None: its default)


@dataclass(frozen=True)
class ReconCloud:
    class_name: str
    heading_deg: float
    tilt_deg: float
    altitude_m: float
    lateral_m: float
    points: npt.NDArray[np.float64]  # (n, 3) world NED; empty when nothing was detected
    seabed_depth: float = float("nan")  # m NED: the seabed recon fitted under the object (NaN: none)


def reconstruct_pass(class_name: str, heading_deg: float, tilt_deg: float, altitude: float, lateral: float,
                     s: PassSettings) -> tuple[npt.NDArray[np.float64], float]:
    """Points of the object recon detects nearest the origin, world NED (``(0, 3)`` if none), and the
    depth of the seabed recon fitted under it (m; NaN if none)."""
    seed = int(np.random.SeedSequence([s.seed, zlib.crc32(class_name.encode()), round(heading_deg * 100),
                                       round(tilt_deg * 100), round(altitude * 100), round(lateral * 100) % 2**32])
               .generate_state(1)[0] & 0x7FFFFFFF)
    sonar = SonarConfig(tilt_deg=tilt_deg, window_start=s.window_start, window_length=s.window_length, fps=s.fps,
                        spread_deg=s.spread_deg, rays_per_beam=s.rays_per_beam)
    scene = Scene(seed=seed, seabed=Seabed(depth=s.depth_m, roughness=s.roughness_m),
                  objects=(SceneObject(class_name, 0.0, 0.0, heading_deg),),
                  survey=Survey(line_length=s.run_in + s.run_out, line_spacing=3.5, lines=1, altitude=altitude,
                                speed=s.speed), sonar=sonar,
                  acoustics=AcousticsTable(profile=s.acoustics))
    renderer = SonarRenderer(scene)
    n = int((s.run_in + s.run_out) / s.speed * s.fps) + 1
    t = np.arange(n) / s.fps
    pos = np.stack([-s.run_in + s.speed * t, np.full(n, lateral), np.full(n, s.depth_m - altitude)], axis=1)
    zeros = np.zeros(n)
    traj = Trajectory.from_euler(t, pos, zeros, zeros, zeros, altitude=np.full(n, altitude))
    geom = SonarGeometry.from_degrees(tilt_deg=tilt_deg, spread_deg=s.spread_deg, window_start=s.window_start,
                                      window_length=s.window_length)
    config = default_recon_config()
    if s.highlight_k is not None:
        config = replace(config, highlight=replace(config.highlight, k=s.highlight_k))
    if s.carve_front_slope is not None:
        config = replace(config, front_slope=s.carve_front_slope)
    if s.calibrate is not None:
        config = replace(config, calibrate=s.calibrate)
    rec = Reconstructor(geom, traj, config)
    for i in range(n):
        rec.add_frame(float(t[i]), renderer.render(pos[i], 0.0, 0.0, 0.0, frame_rng(seed, i)))
    objects = rec.finish()
    if not objects:
        return np.zeros((0, 3)), float("nan")
    best = min(objects, key=lambda o: float(np.hypot(o.centroid[0], o.centroid[1])))
    return np.asarray(best.points, dtype=np.float64), float(rec.seabed_depth_at(best.centroid[None, :2])[0])


def standard_passes(quick: bool = False, acoustics: ProfileName = "ideal") -> PassSettings:
    """The evaluation passes of ``auvlink eval --recon`` and the benchmark (seed 11; no training draw
    uses the simulator or recon at all), rendered under the sonar profile ``acoustics``."""
    if quick:
        return PassSettings(headings_deg=(10.0, 145.0, 280.0), tilts_deg=(30.0,), altitudes_m=(4.0, 5.0), seed=11,
                            acoustics=acoustics)
    return PassSettings(altitudes_m=(4.0, 5.0), laterals_m=(-0.7, 0.5), seed=11, acoustics=acoustics)


def iter_passes(class_names: Sequence[str], s: PassSettings) -> Iterator[tuple[str, float, float, float, float]]:
    for name in class_names:
        for h in s.headings_deg:
            for tilt in s.tilts_deg:
                for alt in s.altitudes_m:
                    for lat in s.laterals_m:
                        yield name, h, tilt, alt, lat


def _code_hash(s: PassSettings, class_names: Sequence[str]) -> str:
    """Hash of the settings, of the simulator's and recon's source and of the module holding the pipeline's
    recon settings (any of them changes: new clouds)."""
    h = hashlib.sha256(json.dumps({"s": asdict(s), "classes": list(class_names)}, sort_keys=True).encode())
    for pkg in (recon, sim):
        for f in sorted(Path(str(pkg.__file__)).parent.rglob("*.py")):
            h.update(f.read_bytes())
    h.update(Path(str(inspect.getsourcefile(default_recon_config))).read_bytes())
    return h.hexdigest()[:20]


def reconstruct_set(class_names: Sequence[str], s: PassSettings, progress: bool = False,
                    cache_dir: Any = None) -> list[ReconCloud]:
    """Every pass of ``s`` for every class; cached under ``cache_dir`` (keyed by the settings and the
    source of the simulator and recon) when given."""
    jobs = list(iter_passes(class_names, s))
    path = Path(cache_dir) / f"recon-{_code_hash(s, class_names)}.npz" if cache_dir is not None else None
    if path is not None and path.is_file():
        with np.load(path) as z:
            parts = np.split(np.asarray(z["points"], dtype=np.float64), z["splits"])
            depths = np.asarray(z["seabed"], dtype=np.float64)
        return [ReconCloud(*job, p, float(d)) for job, p, d in zip(jobs, parts, depths, strict=True)]
    out = []
    for name, h, tilt, alt, lat in progress_bar(jobs, enabled=progress, desc="simulate+recon"):
        pts, depth = reconstruct_pass(name, h, tilt, alt, lat, s)
        out.append(ReconCloud(name, h, tilt, alt, lat, pts, depth))
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.stem + f".{os.getpid()}.tmp.npz")
        np.savez_compressed(tmp, points=np.concatenate([c.points for c in out]).reshape(-1, 3),
                            splits=np.cumsum([len(c.points) for c in out])[:-1],
                            seabed=np.array([c.seabed_depth for c in out]))
        os.replace(tmp, path)
    return out


def evaluate_recon(clf: Classifier, clouds: Sequence[ReconCloud], min_points: int = 8) -> tuple[EvalReport, int]:
    """The classifier's report on the clouds with at least ``min_points`` points, and how many had fewer
    (passes where recon detected nothing are not classification errors; they are counted apart)."""
    got = [c for c in clouds if len(c.points) >= min_points]
    pred = [clf.class_names.index(k) for k, _ in clf.classify_many([c.points for c in got],
                                                                  [c.seabed_depth for c in got])] if got else []
    true = [clf.class_names.index(c.class_name) for c in got]
    return EvalReport.from_predictions(clf.class_names, true, pred), len(clouds) - len(got)


def horizontal_extent(points: npt.NDArray[np.float64]) -> float:
    """Largest horizontal distance of the cloud's points from their mean (m)."""
    if len(points) == 0:
        return 0.0
    d = points[:, :2] - points[:, :2].mean(axis=0)
    return float(math.sqrt(float((d**2).sum(axis=1).max())))


def recon_metrics(cache_dir: Path | None = None, progress: bool = False, acoustics: ProfileName = "ideal",
                  quick: bool = False) -> Callable[[Classifier], dict[str, Any]]:
    """The check ``auvlink train --recon-eval`` adds to :func:`classify.training.workflow.train_and_save`: the trained
    classifier on the clouds of :func:`standard_passes` rendered under ``acoustics`` (evaluation only, never
    training data)."""

    def run(clf: Classifier) -> dict[str, Any]:
        passes = standard_passes(quick, acoustics)
        clouds = reconstruct_set(clf.object_classes, passes, progress, cache_dir)
        rep, missed = evaluate_recon(clf, clouds)
        return {"passes": asdict(passes), "n_passes": len(clouds), "not_detected": missed, **rep.to_dict()}

    return run
