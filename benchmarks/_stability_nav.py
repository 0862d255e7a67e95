"""Long-mission dead reckoning for the ``stability`` stage: error growth against the random-walk theory.

An ensemble of missions (default 10 h) flown straight at ``speed`` m/s due north, level, with the
simulator's default sensor noise (:mod:`auvlink.sim.noise`): DVL white velocity noise
``velocity_sigma`` per axis at ``dvl_hz`` and its scale error ``scale_error``; gyro angle random walk
``arw`` plus a first-order Gauss-Markov bias (``bias_instability`` steady-state sigma,
``bias_correlation_s``). Each mission goes through :func:`recon.nav.dead_reckon` with the true start
heading (the compass start-up error, a constant heading offset, is a separate, linear term).

Theory, per axis (t = mission time, V = speed, dt = DVL interval):
- along-track: the DVL scale error gives a bias ``scale_error V t`` (removed before comparing) and the
  white velocity noise a random walk, variance ``sigma_v^2 dt t``: growth exponent 1/2;
- cross-track: the same ``sigma_v^2 dt t`` plus the heading error integrated at speed V. The gyro's
  white rate noise makes heading a random walk, so the position variance grows as
  ``V^2 arw^2 t^3 / 3`` (exponent 3/2); the Gauss-Markov bias adds
  ``V^2 int int (t-u)(t-u') sigma_b^2 exp(-|u-u'|/tau) du du'`` (t^4 at t << tau, t^3 at t >> tau).
The measured RMS over the ensemble is fitted on log-spaced times (log-log slope) and compared with
the theory curve fitted on the same window, and its level at the end with the theory's.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from scipy.signal import lfilter

from auvlink.sim.noise import DvlNoise, GyroNoise
from recon.nav import DepthSamples, DvlSamples, GyroSamples, NavConfig, dead_reckon


def _gauss_markov(rng: np.random.Generator, n: int, sigma: float, tau: float, dt: float) -> np.ndarray:
    """Stationary first-order Gauss-Markov sequence (AR(1)) of steady-state sigma ``sigma``."""
    a = math.exp(-dt / tau)
    w = rng.normal(0.0, sigma * math.sqrt(1.0 - a * a), n)
    w[0] = rng.normal(0.0, sigma)
    return np.asarray(lfilter([1.0], [1.0, -a], w), dtype=np.float64)


def one_mission(seed: int, hours: float, speed: float, dvl_hz: float, gyro_hz: float,
                dvl: DvlNoise, gyro: GyroNoise, sample_t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(along-track, cross-track) errors [m] at ``sample_t`` of one dead-reckoned mission."""
    rng = np.random.default_rng(seed)
    dur = hours * 3600.0
    tv = np.arange(0.0, dur + 1e-9, 1.0 / dvl_hz)
    tg = np.arange(0.0, dur + 1e-9, 1.0 / gyro_hz)
    v_true = np.zeros((tv.size, 3))
    v_true[:, 0] = speed
    v_meas = (1.0 + dvl.scale_error) * v_true + rng.normal(0.0, dvl.velocity_sigma, (tv.size, 3))
    dtg = 1.0 / gyro_hz
    rate = rng.normal(0.0, gyro.arw / math.sqrt(dtg), tg.size)
    rate += _gauss_markov(rng, tg.size, gyro.bias_sigma, gyro.bias_correlation_s, dtg)
    traj = dead_reckon(
        DvlSamples(tv, v_meas, frame="body", bottom_track=False, altitude=np.full(tv.size, 5.0),
                   pitch=np.zeros(tv.size), roll=np.zeros(tv.size)),
        GyroSamples(tg, rate, kind="rate"),
        DepthSamples(np.array([0.0, dur]), np.full(2, 101325.0 + 1025.0 * 9.80665 * 20.0)),
        NavConfig(initial_heading=0.0),
    )
    pos, _ = traj.pose_at(sample_t)
    along = pos[:, 0] - speed * sample_t
    cross = pos[:, 1]
    return along, cross


def _gm_cross_variance(t: np.ndarray, speed: float, sigma_b: float, tau: float) -> np.ndarray:
    """V^2 int_0^t int_0^t (t-u)(t-u') sigma_b^2 exp(-|u-u'|/tau) du du', numerically (600-point grid)."""
    out = np.zeros(t.size)
    for i, ti in enumerate(t):
        u = (np.arange(600) + 0.5) * ti / 600
        du = ti / 600
        w = (ti - u) * du
        k = sigma_b * sigma_b * np.exp(-np.abs(u[:, None] - u[None, :]) / tau)
        out[i] = speed * speed * float(w @ k @ w)
    return out


def theory(t: np.ndarray, speed: float, dvl_hz: float, dvl: DvlNoise, gyro: GyroNoise
           ) -> tuple[np.ndarray, np.ndarray]:
    """Expected RMS (along-track after the scale bias, cross-track) at times ``t``."""
    vel = dvl.velocity_sigma ** 2 * (1.0 / dvl_hz) * t
    along = np.sqrt(vel)
    cross = np.sqrt(vel + speed * speed * gyro.arw ** 2 * t ** 3 / 3.0
                    + _gm_cross_variance(t, speed, gyro.bias_sigma, gyro.bias_correlation_s))
    return along, cross


def slope(t: np.ndarray, y: np.ndarray, lo: float, hi: float) -> float:
    """Least-squares slope of log y against log t for lo <= t <= hi."""
    m = (t >= lo) & (t <= hi) & (y > 0)
    return float(np.polyfit(np.log(t[m]), np.log(y[m]), 1)[0])


def run_dead_reckoning(hours: float, runs: int, gyro_hz: float = 10.0, seed: int = 7,
                       speed: float = 1.0) -> dict[str, Any]:
    """The ensemble, its fitted exponents and levels against the theory, and stability rows."""
    dvl, gyro = DvlNoise(), GyroNoise()
    dvl_hz = 5.0
    t0 = time.perf_counter()
    dur = hours * 3600.0
    ts = np.geomspace(10.0, dur, 40)
    along = np.zeros((runs, ts.size))
    cross = np.zeros((runs, ts.size))
    for k in range(runs):
        a, c = one_mission(seed + k, hours, speed, dvl_hz, gyro_hz, dvl, gyro, ts)
        along[k], cross[k] = a, c
    scale_bias = dvl.scale_error * speed * ts
    rms_along = np.sqrt(np.mean((along - scale_bias) ** 2, axis=0))
    rms_cross = np.sqrt(np.mean(cross ** 2, axis=0))
    mean_bias = float(np.mean(along[:, -1]))
    th_along, th_cross = theory(ts, speed, dvl_hz, dvl, gyro)
    late = (min(3600.0, dur / 4), dur)
    early = (10.0, min(100.0, dur))
    fits = {
        "along_slope": slope(ts, rms_along, 10.0, dur), "along_slope_theory": slope(ts, th_along, 10.0, dur),
        "cross_slope_late": slope(ts, rms_cross, *late), "cross_slope_late_theory": slope(ts, th_cross, *late),
        "cross_slope_early": slope(ts, rms_cross, *early),
        "cross_slope_early_theory": slope(ts, th_cross, *early),
        "along_rms_end_m": float(rms_along[-1]), "along_rms_end_theory_m": float(th_along[-1]),
        "cross_rms_end_m": float(rms_cross[-1]), "cross_rms_end_theory_m": float(th_cross[-1]),
        "along_bias_end_m": mean_bias, "along_bias_end_expected_m": float(scale_bias[-1]),
    }
    # the ensemble RMS of `runs` missions scatters by about 1/sqrt(2 runs) around the theory
    tol_level = 3.0 / math.sqrt(2.0 * runs)
    tol_slope = 0.15 if runs >= 16 else 0.3
    h = f"{hours:g} h"
    rows = [
        {"case": f"nav: {h} dead reckoning, along-track growth exponent (theory 1/2, velocity white noise)",
         "ok": abs(fits["along_slope"] - fits["along_slope_theory"]) < tol_slope,
         "detail": f"fit {fits['along_slope']:.3f} vs theory curve {fits['along_slope_theory']:.3f} "
                   f"over 10 s-{h}, {runs} runs (tolerance {tol_slope})"},
        {"case": f"nav: {h} dead reckoning, cross-track growth exponent (theory 3/2, heading random walk)",
         "ok": abs(fits["cross_slope_late"] - fits["cross_slope_late_theory"]) < tol_slope,
         "detail": f"fit {fits['cross_slope_late']:.3f} vs theory curve {fits['cross_slope_late_theory']:.3f} "
                   f"over {late[0]:.0f} s-{h}; early (10-100 s, velocity noise dominates) "
                   f"{fits['cross_slope_early']:.3f} vs {fits['cross_slope_early_theory']:.3f}"},
        {"case": f"nav: {h} dead reckoning, error level at the end against the random-walk theory",
         "ok": all(abs(math.log(fits[f"{ax}_rms_end_m"] / fits[f"{ax}_rms_end_theory_m"])) < tol_level
                   for ax in ("along", "cross")),
         "detail": f"RMS along-track (scale bias removed) {fits['along_rms_end_m']:.3f} m vs theory "
                   f"{fits['along_rms_end_theory_m']:.3f} m; cross-track {fits['cross_rms_end_m']:.2f} m vs "
                   f"{fits['cross_rms_end_theory_m']:.2f} m (log ratio tolerance {tol_level:.2f})"},
        {"case": f"nav: {h} dead reckoning, DVL scale error {dvl.scale_error:g} gives the expected bias",
         "ok": abs(mean_bias - scale_bias[-1]) < 3.0 * rms_along[-1] / math.sqrt(runs) + 1e-6,
         "detail": f"mean along-track error at the end {mean_bias:.2f} m vs scale_error x distance "
                   f"{scale_bias[-1]:.2f} m"},
    ]
    curves = {"t_s": ts, "rms_along_m": rms_along, "rms_cross_m": rms_cross, "theory_along_m": th_along,
              "theory_cross_m": th_cross}
    return {"hours": hours, "runs": runs, "gyro_hz": gyro_hz, "dvl_hz": dvl_hz, "speed": speed,
            "noise": {"velocity_sigma": dvl.velocity_sigma, "scale_error": dvl.scale_error,
                      "arw_rad_per_sqrt_s": gyro.arw, "bias_sigma_rad_s": gyro.bias_sigma,
                      "bias_correlation_s": gyro.bias_correlation_s},
            **fits, "curves": curves, "rows": rows, "seconds": time.perf_counter() - t0}
