"""Training clouds from simulated surveys: the clouds recon hands the classifier, over the survey space and the
acoustic space (the survey stage of ``auvlink train``, ``[surveys]``).

Each survey of a draw (:mod:`auvlink.evaluation.draw`, flown with one sonar model or one drawn per survey) is
rendered under acoustic conditions drawn with it (:mod:`auvlink.evaluation.acoustic_draw`, ``random``: over the
profile of the survey's sonar, its beam pattern, sidelobe level, pulse, gain, TVG error, noise floor and
interference drawn over the space), simulated into a
temporary log (:func:`auvlink.sim.mission.simulate_to_log`) and replayed without classification
(:func:`auvlink.pipeline.process.run_log`: every object recon finalizes is kept). Each object is labelled with the
class of the true object within :data:`MATCH_M` of its centre, else ``clutter`` (a crest of the seabed, a sidelobe
arc or a piece of interference recon clustered), and its cloud normalized as synthesis does
(:func:`classify.normalize.normalize_cloud`: the settings' ``scale_m`` and ``z_ref``, recon's seabed depth under
the object) and drawn to the settings' ``n_points``. The meshes are the catalogue's, as in every synthesis mode;
what this adds is the whole chain between them and the classifier: the rendered image, recon's highlight
extension, seabed removal, clustering and the fusion of passes. Keep the draw seed apart from the seeds a model
is evaluated on.

Each survey's clouds are cached (``CACHE/surveys/KEY-NNNN.npz``, the key from the seed, the survey's acoustic
space, the sonar, the normalization and a digest of the code the clouds pass through, :func:`code_digest`), so a
longer draw reuses a shorter one's surveys and a changed recon or simulator harvests afresh. Surveys run in ``workers``
processes (spawned, one thread each); the clouds do not depend on the number of workers.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import json
import multiprocessing as mp
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from auvlink.evaluation.acoustic_draw import AcousticDraw, draw_acoustics
from auvlink.evaluation.draw import SurveyDraw, draw_surveys
from auvlink.evaluation.surveys import worker_init
from auvlink.progress import progress_bar
from classify.decision import EVIDENCE
from classify.labels import CLUTTER
from classify.normalize import normalize_cloud
from classify.training.dataset import CloudSet

#: an object found within this horizontal distance (m) of a true object's position is that object: the
#: evaluation's own match radius (:mod:`auvlink.evaluation.survey_scores`, precision and recall at 1 m)
MATCH_M = 1.0
#: version of the cached survey clouds (bumped when what is stored changes)
CACHE_VERSION = 1
#: the packages a survey's clouds pass through: the simulator that renders it, the codecs of its log, the engine
#: and recon that replay it
CODE_PACKAGES = ("auvlink.sim", "auvlink.codecs", "auvlink.pipeline", "recon")


@dataclass(frozen=True)
class CloudJob:
    """One survey to harvest: its draw, acoustics, the normalization and where its clouds are cached."""

    draw: SurveyDraw
    acoustics: AcousticDraw
    n_points: int
    scale_m: float
    z_ref: str
    cache: Path | None
    seed: int
    evidence: bool = False  # the objects' evidence is needed (a cached file without it is harvested again)


def label_objects(positions_ne: npt.NDArray[np.float64], truth: Sequence[tuple[str, float, float]]) -> list[str]:
    """The class of the true object ``(class, north, east)`` nearest each position ``(k, 2)`` (m) when within
    :data:`MATCH_M`, else ``clutter``."""
    if not len(truth):
        return [CLUTTER] * len(positions_ne)
    t = np.array([[n, e] for _, n, e in truth], dtype=np.float64)
    d = np.hypot(positions_ne[:, None, 0] - t[None, :, 0], positions_ne[:, None, 1] - t[None, :, 1])
    j = d.argmin(axis=1)
    return [truth[int(k)][0] if d[i, k] <= MATCH_M else CLUTTER for i, k in enumerate(j)]


def harvest_survey(job: CloudJob) -> dict[str, Any]:
    """Simulate and replay one survey; its clouds ``(k, n_points, 3)`` float32, labels, shadow heights (m), heading
    and tilt (deg), and each object's evidence ``(k, len(classify.decision.EVIDENCE))``."""
    if job.cache is not None and job.cache.is_file():
        with np.load(job.cache, allow_pickle=False) as z:
            if not job.evidence or "evidence" in z.files:
                return {k: z[k] for k in z.files}
    from auvlink.pipeline.process import run_log
    from auvlink.sim.mission import simulate_to_log
    from auvlink.sim.scene import load_scene

    d = job.draw
    rng = np.random.default_rng(np.random.SeedSequence([job.seed, d.index, 0xC10D]))
    with tempfile.TemporaryDirectory(prefix="auvlink-survey-clouds-") as tmp:
        scene_path = Path(tmp) / "scene.toml"
        table = job.acoustics.table_toml()
        scene_path.write_text(d.scene_toml() + ("\n" + table if table else ""))
        log = Path(tmp) / "mission.mcap"
        simulate_to_log(load_scene(scene_path), log, progress=False, workers=1)
        result = run_log(log, classify=False, progress=False, torch_threads=None)
    dets = [x for x in result.detections if x.seabed_depth is not None and len(x.points)]
    pos = np.array([x.position_ned[:2] for x in dets], dtype=np.float64).reshape(-1, 2)
    labels = label_objects(pos, [(c, n, e) for c, n, e, _ in d.objects])
    clouds = np.zeros((len(dets), job.n_points, 3), np.float32)
    for i, x in enumerate(dets):
        pts = np.asarray(x.points, dtype=np.float64)
        pick = rng.choice(len(pts), job.n_points, replace=len(pts) < job.n_points)
        clouds[i] = normalize_cloud(pts[pick], job.scale_m, job.z_ref, float(x.seabed_depth or 0.0))
    heights = np.array([np.nan if x.shadow_height is None else x.shadow_height for x in dets], dtype=np.float64)
    evidence = np.array([x.evidence for x in dets], dtype=np.float64).reshape(len(dets), len(EVIDENCE))
    out = {"clouds": clouds, "labels": np.array(labels, dtype="U32"), "shadow_heights": heights,
           "heading_deg": np.full(len(dets), d.heading_deg), "tilt_deg": np.full(len(dets), d.tilt_deg),
           "evidence": evidence}
    if job.cache is not None:
        job.cache.parent.mkdir(parents=True, exist_ok=True)
        tmp_path = job.cache.with_name(job.cache.name + ".tmp.npz")
        np.savez(tmp_path, clouds=out["clouds"], labels=out["labels"], shadow_heights=out["shadow_heights"],
                 heading_deg=out["heading_deg"], tilt_deg=out["tilt_deg"], evidence=out["evidence"])
        tmp_path.replace(job.cache)
    return out


@functools.cache
def code_digest() -> str:
    """SHA-256 of the source the survey clouds pass through (:data:`CODE_PACKAGES`): a cache made by other code
    (recon placing or thresholding otherwise) is not reused."""
    h = hashlib.sha256()
    for pkg in CODE_PACKAGES:
        root = Path(importlib.import_module(pkg).__file__ or "").parent
        for path in sorted(root.rglob("*.py")):
            h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


def cache_key(seed: int, acoustics: str, sonar: str, n_points: int, scale_m: float, z_ref: str,
              small: bool = False) -> str:
    """The cache key of a draw's survey clouds: what the clouds depend on, the code they pass through included."""
    doc = json.dumps([CACHE_VERSION, seed, acoustics, sonar, n_points, scale_m, z_ref, code_digest()]
                     + (["small"] if small else []))
    return hashlib.sha256(doc.encode()).hexdigest()[:16]


def survey_space(index: int, acoustics: str, ideal_every: int) -> str:
    """The acoustic space survey ``index`` is flown under: ``ideal`` for every ``ideal_every``-th survey
    (indices ``ideal_every - 1``, ``2 ideal_every - 1``, ...; 0: none), else ``acoustics``."""
    return "ideal" if ideal_every > 0 and index % ideal_every == ideal_every - 1 else acoustics


def _harvest(n: int, seed: int, *, n_points: int, scale_m: float, z_ref: str, cache_dir: Path | None, workers: int,
             progress: bool, acoustics: str, sonar: str, small: bool, ideal_every: int,
             evidence: bool) -> list[dict[str, Any]]:
    """Every survey's harvest (:func:`harvest_survey`), in draw order."""
    draws = draw_surveys(n, seed, small, sonar)
    jobs = []
    for d in draws:
        space = survey_space(d.index, acoustics, ideal_every)
        key = cache_key(seed, space, sonar, n_points, scale_m, z_ref, small)
        cache = None if cache_dir is None else Path(cache_dir) / "surveys" / f"{key}-{d.index:04d}.npz"
        jobs.append(CloudJob(d, draw_acoustics(space, seed, d.index, d.window_length, d.sonar), n_points, scale_m,
                             z_ref, cache, seed, evidence))
    parts: list[dict[str, Any]] = []
    bar = progress_bar(total=len(jobs), enabled=progress, desc="survey clouds", leave=False)
    if workers <= 1 or len(jobs) <= 1:
        for j in jobs:
            parts.append(harvest_survey(j))
            bar.update(1)
    else:
        with mp.get_context("spawn").Pool(min(workers, len(jobs)), initializer=worker_init) as pool:
            for part in pool.imap(harvest_survey, jobs):
                parts.append(part)
                bar.update(1)
            pool.close()  # the workers end on their own (terminating them leaks their semaphores)
            pool.join()
    bar.close()
    return parts


def _cloud_set(parts: Sequence[dict[str, Any]], class_names: Sequence[str], n_points: int, scale_m: float,
               z_ref: str) -> tuple[CloudSet, npt.NDArray[np.bool_]]:
    """The harvests' clouds of the classes ``class_names`` as one :class:`CloudSet`, and which clouds were kept."""
    names = list(class_names)
    clouds = np.concatenate([p["clouds"] for p in parts]) if parts else np.zeros((0, n_points, 3), np.float32)
    labels = np.concatenate([p["labels"] for p in parts]) if parts else np.zeros(0, "U32")
    keep = np.isin(labels, names)
    idx = np.array([names.index(str(x)) for x in labels[keep]], dtype=np.int64)
    heading = np.concatenate([p["heading_deg"] for p in parts])[keep] if parts else np.zeros(0)
    tilt = np.concatenate([p["tilt_deg"] for p in parts])[keep] if parts else np.zeros(0)
    return CloudSet(clouds[keep].astype(np.float32), idx, tuple(names), heading, tilt, scale_m, z_ref,
                    np.ones(int(keep.sum()), bool)), keep


def survey_cloud_set(n: int, seed: int, class_names: Sequence[str], *, n_points: int, scale_m: float, z_ref: str,
                     cache_dir: Path | None = None, workers: int = 2, progress: bool = True,
                     acoustics: str = "random", sonar: str = "didson", small: bool = False,
                     ideal_every: int = 0) -> CloudSet:
    """The clouds of ``n`` surveys of the draw ``seed`` (module docstring; every ``ideal_every``-th flown under the
    idealized model: :func:`survey_space`) as a :class:`CloudSet` (every cloud ``measured``: recon's own seabed
    removal made it); objects of a class outside ``class_names`` are left out (and clutter where ``class_names``
    has none); ``small``: the smoke draw (2 lines, 2 objects a survey)."""
    parts = _harvest(n, seed, n_points=n_points, scale_m=scale_m, z_ref=z_ref, cache_dir=cache_dir, workers=workers,
                     progress=progress, acoustics=acoustics, sonar=sonar, small=small, ideal_every=ideal_every,
                     evidence=False)
    return _cloud_set(parts, class_names, n_points, scale_m, z_ref)[0]


def survey_object_set(n: int, seed: int, class_names: Sequence[str], *, n_points: int, scale_m: float, z_ref: str,
                      cache_dir: Path | None = None, workers: int = 2, progress: bool = True,
                      acoustics: str = "random", sonar: str = "didson", small: bool = False,
                      ideal_every: int = 0) -> tuple[CloudSet, npt.NDArray[np.float64]]:
    """:func:`survey_cloud_set` with each kept object's evidence ``(len(clouds), len(classify.decision.EVIDENCE))``
    (what the decision model of :mod:`classify.decision` is fitted on)."""
    parts = _harvest(n, seed, n_points=n_points, scale_m=scale_m, z_ref=z_ref, cache_dir=cache_dir, workers=workers,
                     progress=progress, acoustics=acoustics, sonar=sonar, small=small, ideal_every=ideal_every,
                     evidence=True)
    data, keep = _cloud_set(parts, class_names, n_points, scale_m, z_ref)
    ev = np.concatenate([p["evidence"] for p in parts]) if parts else np.zeros((0, len(EVIDENCE)))
    return data, ev[keep]
