"""Geometry cases of the ``stability`` stage: hypothesis-driven properties of the recon geometry.

Each function returns ``stability`` rows ({"case", "ok", "detail"}); a property is run by hypothesis
(derandomized: the same examples every run) and a failure's detail names the falsifying example.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from recon import GeometryError, HighlightConfig, ReconConfig, Reconstructor, SonarGeometry, Trajectory, attitude
from recon.highlight import extract, project
from recon.sonar_geometry import paper_minus_exact, points_sonar
from recon.synthetic import Scene, Sphere, render, surface_distance

Row = dict[str, Any]
DEG = math.pi / 180.0


def prop(name: str, examples: int, strategy: Any, check: Callable[..., str]) -> Row:
    """Run ``check(*example)`` over hypothesis examples; it raises AssertionError on a violation and
    returns a short description of the worst value seen."""
    worst: list[str] = []
    failing: list[Any] = []

    @settings(max_examples=examples, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck), print_blob=False)
    @given(strategy)
    def run(ex: Any) -> None:
        try:
            worst.append(check(*ex))
        except AssertionError:
            failing[:] = [ex]
            raise

    try:
        run()
    except AssertionError as exc:
        return {"case": name, "ok": False, "detail": f"falsified by {failing[:1]}: {exc}"}
    except Exception as exc:  # a crash is a failure too, with its type
        return {"case": name, "ok": False, "detail": f"raised {type(exc).__name__}: {exc}"}
    return {"case": name, "ok": True, "detail": f"{examples} examples; {worst[-1] if worst else ''}"}


def brute_onset(g: SonarGeometry, pos: np.ndarray, rot: Rotation, depth: float, n_phi: int = 4001) -> np.ndarray:
    """Per beam, the nearest range at which any ray of the fan meets the plane z = depth (inf: never)."""
    phi = np.linspace(-0.5 * g.spread, 0.5 * g.spread, n_phi)
    d_s = points_sonar(1.0, g.azimuths[:, None], phi[None, :])
    m_ws = rot.as_matrix() @ g.mounting.rotation.as_matrix()
    dz = d_s @ m_ws[2]
    o = pos + rot.as_matrix() @ g.mounting.lever
    h = depth - o[2]
    with np.errstate(divide="ignore"):
        r = np.where(dz > 0, h / np.where(dz > 0, dz, 1.0), np.inf)
    return np.asarray(r.min(axis=1), dtype=np.float64)


def _onset_check(g: SonarGeometry) -> Callable[..., str]:
    def check(yaw: float, pitch: float, roll: float, alt: float, far: float) -> str:
        pos = np.array([far, -far, 30.0])
        rot = attitude(yaw * DEG, pitch * DEG, roll * DEG)
        ours = g.flat_onset_ranges(pos[None], rot, np.array([alt]))[0]
        ref = brute_onset(g, pos, rot, pos[2] + alt)
        both = np.isfinite(ours) & np.isfinite(ref)
        assert np.array_equal(np.isfinite(ours), np.isfinite(ref)), "fan meets the seabed in one but not the other"
        rel = float(np.max(np.abs(ours[both] - ref[both]) / ref[both], initial=0.0))
        assert rel < 1e-6, f"onset off by {rel:.2e} (relative) against the brute-force fan"
        return f"worst relative onset error {rel:.1e}"
    return check


def onset_cases(n: int) -> list[Row]:
    angles = st.tuples(st.floats(-180, 180), st.floats(-30, 30), st.floats(-30, 30), st.floats(0.5, 100),
                       st.sampled_from([0.0, 1e6]))
    rows = []
    for tilt in (0.0, 30.0, 60.0):
        g = SonarGeometry.from_degrees(tilt, lever_arm=(0.4, 0.1, 0.3))
        rows.append(prop(f"recon geometry: tilt {tilt:g} deg, seabed onset of every beam vs a brute-force fan "
                         "(any heading, pitch/roll +-30 deg, 0.5-100 m altitude, 0 or 1e6 m from origin)",
                         n, angles, _onset_check(g)))
    edge = SonarGeometry.from_degrees(30.0, n_beams=9, azimuth_table=tuple(np.linspace(-89.9, 89.9, 9) * DEG))
    rows.append(prop("recon geometry: azimuth edges (beams at +-89.9 deg), onset vs brute-force fan", n, angles,
                     _onset_check(edge)))

    def any_azimuth(az: float, tilt: float, yaw: float, pitch: float, roll: float, alt: float, far: float) -> str:
        """One beam at an arbitrary azimuth inside the fan: onset vs brute force at any attitude, and (level)
        the exact highlight point at the onset range on the seabed."""
        gg = SonarGeometry.from_degrees(tilt, n_beams=1, azimuth_table=(az * DEG,), lever_arm=(0.4, 0.1, 0.3))
        out = _onset_check(gg)(yaw, pitch, roll, alt, far)
        pos = np.array([[far, -far, 30.0]])
        level = attitude(np.array([yaw * DEG]), np.zeros(1), np.zeros(1))
        r = float(gg.flat_onset_ranges(pos, level, np.array([alt]))[0, 0])
        p = pos[0] + level[0].apply(gg.mounting.lever) + r * level[0].apply(gg.highlight_directions("exact")[0])
        err = abs(float(p[2]) - (30.0 + alt)) / r
        assert err < 1e-12, f"exact highlight point {err:.1e} x range off the seabed at azimuth {az} deg"
        return out

    rows.append(prop("recon geometry: any azimuth in the fan (+-14.5 deg, one beam), tilt 0-60 deg, any attitude "
                     "(pitch/roll +-30 deg), 0 or 1e6 m out: onset vs brute-force fan, highlight point on the seabed",
                     n, st.tuples(st.floats(-14.5, 14.5), st.floats(0, 60), st.floats(-180, 180), st.floats(-30, 30),
                                  st.floats(-30, 30), st.floats(0.5, 100), st.sampled_from([0.0, 1e6])),
                     any_azimuth))
    try:
        SonarGeometry.from_degrees(30.0, n_beams=2, azimuth_table=(-math.pi / 2, math.pi / 2))
        rows.append({"case": "recon geometry: azimuth table at +-90 deg rejected", "ok": False,
                     "detail": "accepted an azimuth of 90 deg"})
    except GeometryError as exc:
        rows.append({"case": "recon geometry: azimuth table at +-90 deg rejected", "ok": True, "detail": str(exc)})
    g = SonarGeometry()
    d = paper_minus_exact(g, 10.0)
    rows.append({"case": "recon geometry: exact and paper highlight rays agree on boresight, differ at the edges",
                 "ok": bool(d[g.n_beams // 2] < 0.02 and d.max() > d[g.n_beams // 2]),
                 "detail": f"at 10 m: {d[g.n_beams // 2] * 1000:.2f} mm at the middle beam, "
                           f"{d.max() * 100:.1f} cm at +-14.5 deg"})

    def on_seabed(tilt: float, yaw: float, alt: float) -> str:
        gg = SonarGeometry.from_degrees(tilt)
        rot = attitude(yaw * DEG, 0.0, 0.0)
        pos = np.array([5.0, 3.0, 10.0])
        r = gg.flat_onset_ranges(pos[None], rot, np.array([alt]))[0]
        p = pos + r[:, None] * rot.apply(gg.highlight_directions("exact"))
        err = float(np.abs(p[:, 2] - (pos[2] + alt)).max() / r.max())
        assert err < 1e-12, f"exact highlight point {err:.1e} x range off the seabed"
        return f"worst {err:.1e} x range"

    rows.append(prop("recon geometry: tilt 0-60 deg, the exact highlight ray at the onset range lies on the seabed",
                     n, st.tuples(st.floats(0, 60), st.floats(-180, 180), st.floats(0.5, 50)), on_seabed))
    return rows


def _returns(g: SonarGeometry, n_frames: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    fi = np.repeat(np.arange(n_frames), g.n_beams)
    bi = np.tile(np.arange(g.n_beams), n_frames)
    ri = (bi * 37 + 11) % g.n_bins  # the same returns in every frame
    return fi, bi, ri


def wrap_far_cases(n: int) -> list[Row]:
    g = SonarGeometry(lever_arm=(0.5, 0.0, 0.2))
    fi, bi, ri = _returns(g, 2)

    def wrap(eps: float, x: float, y: float) -> str:
        pos = np.array([[x, y, 20.0]] * 2)
        rot = attitude(np.array([math.pi - eps, -math.pi + eps]), np.zeros(2), np.zeros(2))
        p = project(g, fi, bi, ri, pos, rot).reshape(2, g.n_beams, 3)
        reach = g.window_start + g.window_length + 1.0
        jump = float(np.abs(p[0] - p[1]).max())
        assert jump <= 2 * eps * reach + 1e-9, f"points jump {jump:.3e} m across the wrap"
        same = project(g, fi, bi, ri, pos, attitude(np.array([math.pi, -math.pi]), np.zeros(2), np.zeros(2)))
        d = float(np.abs(same[: g.n_beams] - same[g.n_beams:]).max())
        assert d < 1e-9, f"yaw +180 and -180 deg differ by {d:.2e} m"
        return f"largest jump {jump:.2e} m"

    rows = [prop("recon geometry: heading wrap at +-180 deg, points continuous (yaw pi-e vs -pi+e)", n,
                 st.tuples(st.floats(0, 1e-3), st.floats(-1e6, 1e6), st.floats(-1e6, 1e6)), wrap)]

    def far(x: float, y: float, yaw: float, pitch: float, roll: float) -> str:
        rot = attitude(np.full(2, yaw * DEG), np.full(2, pitch * DEG), np.full(2, roll * DEG))
        near = np.array([[0.3, -0.2, 15.0], [0.8, 0.1, 15.1]])
        off = np.array([x, y, 0.0])
        a = project(g, fi, bi, ri, near, rot)
        b = project(g, fi, bi, ri, near + off, rot) - off
        err = float(np.abs(a - b).max())
        assert err < 1e-3, f"far points differ by {err * 1000:.3f} mm from the near ones"
        return f"worst {err:.1e} m"

    rows.append(prop("recon geometry: positions 1e6 m from the origin give the near-origin points within 1 mm "
                     "(float64)", n, st.tuples(st.floats(-1e6, 1e6), st.floats(-1e6, 1e6), st.floats(-180, 180),
                                               st.floats(-30, 30), st.floats(-30, 30)), far))
    return rows


def pitch_cases() -> list[Row]:
    g = SonarGeometry()
    img = np.zeros((1, g.n_bins, g.n_beams), np.uint8)
    rows = []
    for pitch in (85.0, 89.999, -89.999, 90.0):
        rot = attitude(np.zeros(1), np.array([pitch * DEG]), np.zeros(1))
        name = f"recon: pitch {pitch:g} deg rejected with a clear error"
        try:
            extract(img, np.zeros((1, 3)), rot, np.full((1, g.n_beams), 5.0), g)
            rows.append({"case": name, "ok": False, "detail": "accepted"})
        except GeometryError as exc:
            rows.append({"case": name, "ok": "pitch" in str(exc), "detail": str(exc)})
    rot = attitude(np.zeros(1), np.array([60 * DEG]), np.zeros(1))
    try:
        extract(img, np.zeros((1, 3)), rot, np.full((1, g.n_beams), 5.0), g)
        rows.append({"case": "recon: pitch 60 deg still served", "ok": True, "detail": "accepted"})
    except GeometryError as exc:
        rows.append({"case": "recon: pitch 60 deg still served", "ok": False, "detail": str(exc)})
    return rows


def pass_over_sphere(tilt_deg: float, offset: tuple[float, float], frames: int,
                     config: ReconConfig | None = None) -> tuple[Reconstructor, Scene]:
    """A straight pass (1 m/s, 10 fps) over a 0.5 m sphere through the Reconstructor, at an altitude
    that puts the seabed onset inside the 1-11 m window (5 m; 1 m for tilts under 10 deg)."""
    g = SonarGeometry.from_degrees(tilt_deg)
    ox, oy = offset
    depth, alt = 20.0, (5.0 if tilt_deg >= 10 else 1.0)
    ahead = alt / math.tan(g.tilt + 0.5 * g.spread)
    scene = Scene(seabed_point=(ox, oy, depth), spheres=(Sphere((ox + 4.0 + ahead, oy, depth - 0.4), 0.5),))
    t = np.arange(frames) / 10.0
    pos = np.stack([ox + t, np.full_like(t, oy), np.full_like(t, depth - alt)], axis=1)
    rot = Rotation.from_euler("ZYX", np.zeros((frames, 3)))
    traj = Trajectory(t, pos, rot, altitude=np.full(frames, alt))
    rec = Reconstructor(g, traj, config or ReconConfig(front_slope=False))
    rng = np.random.default_rng(3)
    imgs = np.stack([render(g, pos[i], rot[i], scene, rng)[0] for i in range(frames)])
    rec.add_frames(t, imgs)
    return rec, scene


def tilt_and_far_cases(frames: int) -> list[Row]:
    rows = []
    for tilt in (0.0, 30.0, 60.0):
        rec, scene = pass_over_sphere(tilt, (0.0, 0.0), frames)
        p = rec.raw_points
        med = float(np.median(surface_distance(p, scene))) if len(p) else float("nan")
        rows.append({"case": f"recon end to end: tilt {tilt:g} deg, pass over a 0.5 m sphere, points on its surface",
                     "ok": bool(len(p) > 0 and np.all(np.isfinite(p)) and med < 0.5),
                     "detail": f"{len(p)} points, median distance to the sphere {med * 100:.1f} cm (bound: its "
                               "radius, 50 cm)"})
    near, _ = pass_over_sphere(30.0, (0.0, 0.0), frames)
    far, _ = pass_over_sphere(30.0, (1e6, -1e6), frames)
    on, of = near.finish(), far.finish()
    a, b = near.raw_points, far.raw_points - np.array([1e6, -1e6, 0.0])
    same = a.shape == b.shape
    err = float(np.abs(a - b).max(initial=0.0)) if same else float("inf")
    cerr = (max(float(np.abs(x.centroid - y.centroid + np.array([1e6, -1e6, 0.0])).max()) for x, y in zip(on, of,
            strict=True)) if len(on) == len(of) and on else float("inf"))
    rows.append({"case": "recon end to end: the same pass 1e6 m from the origin (points, seabed removal, DBSCAN)",
                 "ok": bool(same and err < 1e-3 and len(on) == len(of) and cerr < 1e-3),
                 "detail": f"{len(a)} vs {len(b)} points, worst point difference {err:.1e} m; {len(on)} vs "
                           f"{len(of)} objects, worst centroid difference {cerr:.1e} m"})
    return rows


def float32_cases(frames: int) -> tuple[list[Row], list[Row]]:
    """float32 vs float64 projection: stability rows and the dtype tradeoff rows."""
    g = SonarGeometry()
    fi, bi, ri = _returns(g, frames)
    rng = np.random.default_rng(5)
    rot = attitude(rng.uniform(-math.pi, math.pi, frames), rng.uniform(-0.2, 0.2, frames),
                   rng.uniform(-0.2, 0.2, frames))
    rows, trade = [], []
    for label, scale in (("within 1 km of the origin", 1e3), ("1e6 m from the origin", 1e6)):
        pos = rng.uniform(-scale, scale, (frames, 3))
        pos[:, 2] = 20.0
        ref = project(g, fi, bi, ri, pos, rot, "exact", "float64")
        got = project(g, fi, bi, ri, pos, rot, "exact", "float32")
        err = float(np.abs(np.asarray(got, np.float64) - ref).max())
        lim = 1e-3
        rows.append({"case": f"recon: float32 projection {label} within 1 mm of float64",
                     "ok": err < lim, "detail": f"worst {err * 1000:.3f} mm over {len(ref)} points "
                     + ("" if err < lim else "(float32 world coordinates cannot hold mm this far out: keep "
                        "HighlightConfig.dtype='float64' away from the origin)")})
        if scale == 1e3:
            for dt in ("float32", "float64"):
                best = min(_timed(partial(project, g, fi, bi, ri, pos, rot, "exact", dt)) for _ in range(5))
                trade.append({"knob": "projection dtype", "setting": dt, "time_s": best / len(fi) * 1e6,
                              "time_unit": "1e6 points", "error": err if dt == "float32" else 0.0,
                              "error_name": "worst point error vs float64 within 1 km [m]",
                              "default": dt == HighlightConfig().dtype})
    return rows, trade


def _timed(fn: Callable[[], Any]) -> float:
    import time

    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0
