"""Dead-reckoned heading at the lawnmower's turns, noise off: the simulator's gyro through the navigation.

Run: ``python benchmarks/bench_turns.py [--minutes 30]``. The survey of ``bench e2e`` / ``bench geo``
(``survey_scene_text``), without GNSS and with ``[noise] enabled = false``; the DVL's body velocity,
the gyro and the pressure straight from :func:`auvlink.sim.sensors.measure` (no wire, no sonar) into
:func:`recon.nav.dead_reckon` (batch, trapezoid) and :class:`recon.nav_stream.CausalNavigator` (what
replay and live use), started at the true pose. Twice: with the gyro as simulated (each sample the mean
rate over its interval) and with point samples of the true rate at the sample times (the simulator
before). Per run: the heading error at the middle of each line, its change across each turn, and the
horizontal error against the truth (max, p95, end).
"""

from __future__ import annotations

import argparse
import itertools
import time
from typing import Any

import numpy as np


def _xyz(v: Any) -> tuple[float, float, float]:
    """A lever arm (m, body frame) as the 3-tuple the navigation config takes."""
    x, y, z = (float(a) for a in v)
    return x, y, z


def _navigate(m: Any, rate: np.ndarray, cfg: Any) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    from recon.nav import DepthSamples, DvlSamples, GyroSamples, dead_reckon
    from recon.nav_stream import CausalNavigator

    d, g, p = m.dvl, m.gyro, m.pressure

    def dvl(k: Any) -> DvlSamples:
        return DvlSamples(d.t[k], d.velocity_body[k], "body", d.valid[k], d.altitude[k], d.pitch[k], d.roll[k],
                          d.heading[k], bottom_track=False)

    every = np.ones(d.t.size, bool)
    tr = dead_reckon(dvl(every), GyroSamples(g.t, rate, "rate"), DepthSamples(p.t, p.pressure_pa), cfg)
    out = {"batch": (tr.times, tr.positions[:, :2], tr.rotations.as_euler("ZYX")[:, 0])}
    nav = CausalNavigator(cfg)
    edges = np.arange(-1.0, g.t[-1] + 2.0, 0.5)  # half-second blocks, as they come
    for a, b in itertools.pairwise(edges):
        kv, kg, kp = ((t >= a) & (t < b) for t in (d.t, g.t, p.t))
        nav.add(dvl(kv), GyroSamples(g.t[kg], rate[kg], "rate"), DepthSamples(p.t[kp], p.pressure_pa[kp]))
    tt = nav.grid.view[:, 0]
    pos, rot = nav.pose_at(tt)
    out["causal"] = (tt, pos[:, :2], rot.as_euler("ZYX")[:, 0])
    return out


def run(minutes: float = 30.0) -> dict[str, Any]:
    from _sim_log import survey_scene_text

    from auvlink.sim.scene import loads_scene
    from auvlink.sim.sensors import measure
    from auvlink.sim.settings import loads_settings
    from auvlink.sim.trajectory import LawnmowerTrajectory
    from recon.frames import rdi_instrument_mounting
    from recon.nav import NavConfig

    text = survey_scene_text(minutes).replace("[gnss]", "[gnss]\nenabled = false") + "\n[noise]\nenabled = false\n"
    scene, settings = loads_scene(text), loads_settings(text)
    sv = scene.survey
    traj = LawnmowerTrajectory.from_scene(scene)
    m = measure(scene, settings, trajectory=traj)
    start = traj.true_pose(np.array([max(m.gyro.t[0], m.dvl.t[0])]))
    cfg = NavConfig(dvl_mounting=rdi_instrument_mounting(lever_arm=tuple(settings.sensors.dvl_lever_arm)),
                    depth_lever_arm=_xyz(settings.sensors.pressure_lever_arm),
                    initial_heading=float(start.yaw[0]), initial_position=tuple(start.position[0, :2]))
    mids = traj.survey_start + (np.arange(sv.lines) * traj.period + sv.line_length / 2) / sv.speed
    print(f"{minutes:g}-minute survey: {sv.lines} lines, turn rate {sv.speed / traj.radius:.3f} rad/s, "
          f"gyro {settings.sensors.gyro_hz:g} Hz, noise off")
    results: dict[str, Any] = {}
    gyros = {"interval means (now)": m.gyro.rate, "point samples (before)": traj.true_pose(m.gyro.t).angular_rate_body}
    for gname, rate in gyros.items():
        for nname, (t, ne, yaw) in _navigate(m, rate, cfg).items():
            truth = traj.true_pose(t)
            e = np.linalg.norm(ne - truth.position[:, :2], axis=1)
            dyaw = np.degrees(np.angle(np.exp(1j * (yaw - truth.yaw))))
            per_turn = np.diff(np.interp(mids, t, dyaw))
            r = {"turn_change_deg": per_turn.tolist(), "max_turn_change_deg": float(np.abs(per_turn).max()),
                 "max_m": float(e.max()), "p95_m": float(np.percentile(e, 95)), "end_m": float(e[-1])}
            results[f"{gname}, {nname}"] = r
            print(f"{gname:24s} {nname:6s}: heading change per turn (deg) "
                  f"{' '.join(f'{x:+.4f}' for x in per_turn)}; horizontal error max {r['max_m']:.3f} m, "
                  f"p95 {r['p95_m']:.3f} m, end {r['end_m']:.3f} m")
    return results


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=30.0)
    t0 = time.perf_counter()
    run(ap.parse_args().minutes)
    print(f"({time.perf_counter() - t0:.1f} s)")
