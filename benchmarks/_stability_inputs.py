"""Degenerate inputs of the ``stability`` stage: empty and saturated frames, tiny and flat clouds, NaN.

Each case says what the right answer is (no points from a frame without information, one object of
zero extent from identical points, a clear error for NaN) and checks it; an exception where an answer
is expected is a failure with its type and message.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any, Literal

import numpy as np
from scipy.spatial.transform import Rotation

from recon import ClusterConfig, ReconConfig, ReconError, Reconstructor, SonarGeometry, Trajectory, cluster

Row = dict[str, Any]


def case(name: str, fn: Callable[[], tuple[bool, str]]) -> Row:
    try:
        ok, detail = fn()
    except Exception as exc:
        return {"case": name, "ok": False, "detail": f"raised {type(exc).__name__}: {exc}"}
    return {"case": name, "ok": bool(ok), "detail": detail}


def _recon(images: np.ndarray) -> tuple[int, int]:
    """(points, objects) from frames through the Reconstructor on a straight, level pass."""
    g = SonarGeometry()
    n = images.shape[0]
    t = np.arange(n) / 10.0
    tt = np.arange(max(n, 2)) / 10.0
    pos = np.stack([tt, np.zeros(tt.size), np.full(tt.size, 15.0)], axis=1)
    traj = Trajectory(tt, pos, Rotation.identity(tt.size), altitude=np.full(tt.size, 5.0))
    rec = Reconstructor(g, traj, ReconConfig())
    pts = rec.add_frames(t, images)
    return pts, len(rec.finish())


def frame_cases(frames: int) -> list[Row]:
    g = SonarGeometry()
    shape = (frames, g.n_bins, g.n_beams)

    def empty() -> tuple[bool, str]:
        pts, objs = _recon(np.zeros(shape, np.uint8))
        return pts == 0 and objs == 0, f"{pts} points, {objs} objects from {frames} all-zero frames"

    def saturated() -> tuple[bool, str]:
        pts, objs = _recon(np.full(shape, 255, np.uint8))
        return pts == 0 and objs == 0, (f"{pts} points, {objs} objects from {frames} all-255 frames "
                                        "(nothing rises above a saturated background)")

    def no_frames() -> tuple[bool, str]:
        pts, objs = _recon(np.zeros((0, g.n_bins, g.n_beams), np.uint8))
        return pts == 0 and objs == 0, "0 frames: 0 points, 0 objects"

    return [case(f"recon: {frames} empty (all-zero) frames give no points and no objects", empty),
            case(f"recon: {frames} all-saturated frames give no points and no objects", saturated),
            case("recon: an empty stack of frames", no_frames)]


def _clouds(rng: np.random.Generator) -> dict[str, np.ndarray]:
    line = np.zeros((200, 3))
    line[:, 0] = np.linspace(0.0, 2.0, 200)
    return {
        "one point": np.array([[10.0, 5.0, 19.0]]),
        "collinear (200 points on a 2 m line)": line + np.array([10.0, 5.0, 19.0]),
        "zero extent (200 identical points)": np.tile([10.0, 5.0, 19.0], (200, 1)),
        "planar (200 points on a 1 m square, no height)":
            np.column_stack([rng.uniform(0, 1, 200), rng.uniform(0, 1, 200), np.full(200, 19.0)]),
    }


def cloud_cases() -> list[Row]:
    rng = np.random.default_rng(11)
    clouds = _clouds(rng)
    expect = {"one point": 0, "collinear (200 points on a 2 m line)": 1, "zero extent (200 identical points)": 1,
              "planar (200 points on a 1 m square, no height)": 1}
    rows = []
    backends: tuple[Literal["open3d", "sklearn"], ...] = ("open3d", "sklearn")
    for backend in backends:
        cfg = ClusterConfig(backend=backend)

        def run(points: np.ndarray, n_expected: int, cfg: ClusterConfig = cfg) -> tuple[bool, str]:
            objs = cluster(points, np.zeros(len(points)), cfg)
            ext = [np.round(o.extent, 3).tolist() for o in objs]
            finite = all(np.all(np.isfinite(o.centroid)) and np.all(np.isfinite(o.extent)) for o in objs)
            return len(objs) == n_expected and finite, f"{len(objs)} object(s) (expected {n_expected}), extents {ext}"

        def empty(c: ClusterConfig = cfg) -> tuple[bool, str]:
            return cluster(np.zeros((0, 3)), np.zeros(0), c) == [], "no objects"

        rows.append(case(f"cluster ({backend}): empty cloud", empty))
        for name, pts in clouds.items():
            rows.append(case(f"cluster ({backend}): {name}", partial(run, pts, expect[name])))

        def nan(c: ClusterConfig = cfg) -> tuple[bool, str]:
            pts = clouds["collinear (200 points on a 2 m line)"].copy()
            pts[5] = np.nan
            try:
                objs = cluster(pts, np.zeros(len(pts)), c)
            except (ReconError, ValueError) as exc:
                return True, f"rejected: {type(exc).__name__}: {exc}"
            bad = sum(not np.all(np.isfinite(o.centroid)) for o in objs)
            return False, f"accepted a NaN point: {len(objs)} object(s), {bad} with a non-finite centroid"

        rows.append(case(f"cluster ({backend}): a cloud with a NaN point is rejected", nan))
    return rows


def classifier_cases() -> list[Row]:
    from classify.errors import InvalidCloudError
    from classify.infer import Classifier

    clf = Classifier.load()
    rows = []
    for name, pts in _clouds(np.random.default_rng(11)).items():
        def one(p: np.ndarray = pts) -> tuple[bool, str]:
            label, score = clf.classify(p)
            return label in clf.class_names and 0.0 <= score <= 1.0 and np.isfinite(score), \
                f"{label} ({score:.3f})"
        rows.append(case(f"classifier: {name} gives a class and a finite score", one))
    for name, pts in (("NaN", np.array([[0.0, 0.0, 0.0], [np.nan, 1.0, 1.0]] * 10)),
                      ("inf", np.array([[0.0, 0.0, 0.0], [np.inf, 1.0, 1.0]] * 10)),
                      ("empty", np.zeros((0, 3)))):
        def bad(p: np.ndarray = pts) -> tuple[bool, str]:
            try:
                clf.classify(p)
            except InvalidCloudError as exc:
                return True, f"rejected: {exc}"
            return False, "accepted"
        rows.append(case(f"classifier: a cloud with {name} is rejected with a clear error" if name != "empty"
                         else "classifier: an empty cloud is rejected with a clear error", bad))
    return rows
