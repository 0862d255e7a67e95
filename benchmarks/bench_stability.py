"""Numerical stability: a stress suite over extreme geometry, long missions and degenerate inputs.

Run: ``auvlink bench stability --out DIR [--full]`` (or ``python benchmarks/bench_stability.py``).
Every case is a ``stability`` row ({"case", "ok", "detail"}, docs/BENCHMARKS.md); a failed row is a bug.

- Geometry (:mod:`_stability_geometry`, hypothesis, derandomized): the seabed onset of every beam
  against a brute-force fan for tilts 0/30/60 deg, any heading, pitch and roll +-30 deg, 0.5-100 m
  altitude, at the origin and 1e6 m from it; beams at +-89.9 deg azimuth (and +-90 deg rejected);
  the exact highlight ray at the onset lies on the seabed (tilt 0-60 deg); heading wrap at +-180
  deg; positions 1e6 m from the origin against near it (1 mm); pitch near +-90 deg rejected with a
  clear error; the whole Reconstructor on a pass over a sphere at tilts 0/30/60 deg and 1e6 m out.
- Long missions (:mod:`_stability_nav`): dead reckoning over 10 h with the simulator's default
  DVL and gyro noise, an ensemble of missions; the error growth exponent (along-track 1/2, cross-
  track 3/2) and level against the random-walk theory.
- Degenerate inputs (:mod:`_stability_inputs`): empty and all-saturated frames; empty, one-point,
  collinear, zero-extent and planar clouds and a NaN point to DBSCAN (both backends) and to the
  classifier. A long survey through the streaming clusterer (every object once, bounded working set,
  cost per 10 s of mission at 10 h).
- float32 against float64 projection (near the origin and 1e6 m out), also as a ``tradeoffs`` knob.

Sizes: quick = 10 h x 16 missions, 60 hypothesis examples per property, a 60-minute streaming survey;
``--full`` = 10 h x 64, 300 examples, 10 hours of streaming; smoke (``AUVLINK_BENCH_SMOKE=1``) = 1 h x 4
missions, 10 examples, 10 minutes of streaming.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

from _common import script_main, smoke, table, write_json
from _stability_geometry import float32_cases, onset_cases, pitch_cases, tilt_and_far_cases, wrap_far_cases
from _stability_inputs import classifier_cases, cloud_cases, frame_cases, streaming_case
from _stability_nav import run_dead_reckoning


def sizes(quick: bool) -> dict[str, Any]:
    if smoke():
        return {"examples": 10, "hours": 1.0, "runs": 4, "gyro_hz": 5.0, "frames": 60, "stream_min": 10.0}
    if quick:
        return {"examples": 60, "hours": 10.0, "runs": 16, "gyro_hz": 10.0, "frames": 120, "stream_min": 60.0}
    return {"examples": 300, "hours": 10.0, "runs": 64, "gyro_hz": 10.0, "frames": 120, "stream_min": 600.0}


def nav_plot(nav: dict[str, Any]) -> dict[str, Any]:
    """The error growth curves as a ``plots`` entry of the report (log-log)."""
    c = nav["curves"]
    return {"title": f"dead reckoning error growth, {nav['hours']:g} h, {nav['runs']} missions",
            "x": c["t_s"], "xlabel": "mission time [s]", "ylabel": "RMS error [m]", "loglog": True,
            "series": {"along-track (scale bias removed)": c["rms_along_m"],
                       "along-track theory (sqrt t)": c["theory_along_m"],
                       "cross-track": c["rms_cross_m"], "cross-track theory (-> t^1.5)": c["theory_cross_m"]}}


def run(quick: bool = True, out_dir: Path = Path("bench-out")) -> dict[str, Any]:
    t0 = time.perf_counter()
    sz = sizes(quick)
    rows: list[dict[str, Any]] = []
    timings: dict[str, float] = {}

    def section(name: str, fn: Any, *args: Any) -> Any:
        s = time.perf_counter()
        out = fn(*args)
        timings[name] = time.perf_counter() - s
        return out

    rows += section("onset", onset_cases, sz["examples"])
    rows += section("wrap_far", wrap_far_cases, sz["examples"])
    rows += section("pitch", pitch_cases)
    rows += section("end_to_end", tilt_and_far_cases, sz["frames"])
    f32_rows, trade = section("float32", float32_cases, 50)
    rows += f32_rows
    rows += section("frames", frame_cases, 20)
    rows += section("clouds", cloud_cases)
    rows += section("classifier", classifier_cases)
    stream_row, stream = section("streaming", streaming_case, sz["stream_min"])
    rows.append(stream_row)
    nav = section("dead_reckoning", run_dead_reckoning, sz["hours"], sz["runs"], sz["gyro_hz"])
    rows += nav.pop("rows")
    failed = [r for r in rows if not r["ok"]]
    print(table(rows, ["ok", "case", "detail"]))
    print(f"\n{len(rows) - len(failed)}/{len(rows)} stability cases ok; dead reckoning {nav['hours']:g} h x "
          f"{nav['runs']}: cross-track exponent {nav['cross_slope_late']:.2f} (theory curve "
          f"{nav['cross_slope_late_theory']:.2f}), along-track {nav['along_slope']:.2f} "
          f"({nav['along_slope_theory']:.2f}); RMS at the end {nav['cross_rms_end_m']:.1f} m cross-track vs "
          f"{nav['cross_rms_end_theory_m']:.1f} m theory")
    result = {
        "sizes": sz, "cases": len(rows), "failed": len(failed), "stability": rows, "tradeoffs": trade,
        "dead_reckoning": {k: v for k, v in nav.items() if k != "curves"}, "plots": [nav_plot(nav)],
        "streaming": stream,
        "section_s": timings, "loadavg": list(os.getloadavg()), "elapsed_s": time.perf_counter() - t0,
    }
    write_json(out_dir, "stability", result)
    return result


if __name__ == "__main__":
    script_main(run, __doc__)
