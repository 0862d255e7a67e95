"""``auvlink bench --smoke``: every stage runs on tiny inputs, results.json and bench.html hold them all.

This is the CI run that keeps the benchmark scripts from rotting (all stages in well under two minutes
on the 2-core build machine). The figures are not meant to be quoted; the checks are that every stage
ran without error, wrote its contract lists (docs/BENCHMARKS.md) with sane values, that every stability
case holds, and that the report shows every plot.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from image_checks import assert_plot_drawn

from auvlink.cli.bench import STAGES, available_stages, benchmarks_dir

pytestmark = [pytest.mark.timeout(600), pytest.mark.slow]

#: the smoke budget is 20 s per stage on a quiet machine; the 2-core build machine is shared, so the
#: guard (a hang or a runaway smoke setting, not a benchmark) scales with the load when the run began
STAGE_LIMIT_S = 40.0
TOTAL_LIMIT_S = 180.0


def _load_factor_now() -> float:
    """How many times over the machine is booked (1-minute load per core, at least 1)."""
    return max(1.0, os.getloadavg()[0] / (os.cpu_count() or 1))


LOAD_AT_START = _load_factor_now()

Run = tuple[Path, dict[str, Any], "subprocess.CompletedProcess[str]", float]


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> Run:
    out = tmp_path_factory.mktemp("bench-smoke")
    env = {**os.environ, "AUVLINK_BENCH_SMOKE": "1"}
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", "import sys; from auvlink.cli import main; sys.exit(main(sys.argv[1:]))",
         "bench", "--smoke", "--out", str(out)], capture_output=True, text=True, env=env, timeout=580)
    wall = time.perf_counter() - t0
    path = out / "results.json"
    results = json.loads(path.read_text()) if path.is_file() else {}
    return out, results, proc, wall


def _slug(text: str) -> str:
    sys.path.insert(0, str(benchmarks_dir()))
    import report

    return str(report.slug(text))


def test_every_stage_runs_green(smoke_run: Run) -> None:
    out, results, proc, wall = smoke_run
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert set(available_stages()) == set(STAGES), "a stage script is missing"
    assert results["mode"] == "smoke"
    assert set(results["stages"]) == set(STAGES)
    load = max(_load_factor_now(), LOAD_AT_START)
    for stage, res in results["stages"].items():
        assert "error" not in res, f"{stage}: {res.get('error')}"
        assert res["mode"] == "smoke"
        assert 0 < res["wall_s"] < STAGE_LIMIT_S * load, f"{stage} took {res['wall_s']:.1f} s in smoke mode"
        assert (out / f"{stage}.json").is_file()
    assert wall < TOTAL_LIMIT_S * load
    assert results["machine"]["cores"] >= 1 and results["command"].startswith("auvlink bench")


def test_contract_lists_hold_sane_values(smoke_run: Run) -> None:
    _, results, _, _ = smoke_run
    n_trade = n_peers = 0
    for stage, res in results["stages"].items():
        knobs: dict[str, list[dict[str, Any]]] = {}
        for row in res.get("tradeoffs", []):
            knobs.setdefault(row["knob"], []).append(row)
            assert math.isfinite(row["time_s"]) and row["time_s"] > 0, (stage, row)
            assert math.isfinite(row["error"]) and row["error"] >= 0, (stage, row)
            assert row["time_unit"] and row["error_name"]
            n_trade += 1
        for knob, rows in knobs.items():
            assert len(rows) >= 2, f"{stage}/{knob}: a sweep needs two settings"
            assert sum(bool(r["default"]) for r in rows) <= 1, f"{stage}/{knob}: more than one default"
        for p in res.get("peers", []):
            assert p["ours_s"] > 0 and p["peer_s"] > 0
            assert p["ratio"] == pytest.approx(p["peer_s"] / p["ours_s"], rel=1e-9)
            n_peers += 1
        for c in res.get("stability", []):
            assert isinstance(c["ok"], bool) and c["case"] and c["detail"]
    assert n_trade >= 8 and n_peers >= 2


def test_sim_and_decode_figures(smoke_run: Run) -> None:
    _, results, _, _ = smoke_run
    sim = results["stages"]["sim"]
    ks = {r["setting"]: r for r in sim["tradeoffs"] if r["knob"] == "rays per beam K"}
    assert set(ks) == {8, 16, 32, 64} and ks[32]["default"]
    # more rays per beam, a finer highlight (K=8 vs the K=512 reference is centimetres)
    assert ks[8]["error"] > ks[64]["error"] and 0 < ks[64]["error"] < 0.05
    bins = {r["setting"]: r["error"] for r in sim["tradeoffs"] if r["knob"] == "range bins"}
    assert bins[128] > bins[1024] and bins[128] < 0.1
    for peer in sim["peers"]:
        assert peer["identical"] is True, "culling changed the image bytes"
    decode = results["stages"]["decode"]
    hostile = decode["hostile"]  # every framer on garbage and its worst patterns: a rate, a bounded buffer
    from auvlink.framing.hostile import WORST_PATTERNS

    assert {r["format"] for r in hostile} == set(WORST_PATTERNS)
    assert len(hostile) == sum(1 + len(p) for p in WORST_PATTERNS.values())
    assert all(r["bounded"] and r["mb_per_s"] > 0 and r["frames"] == 0 for r in hostile), hostile
    notes = decode.get("notes", {})
    if "pd0" not in notes:  # the capture is in ../shared/data
        bulk = [p for p in decode["peers"] if p["peer"] == "pd0 framer+decode (auvlink)"]
        assert len(bulk) == 1 and bulk[0]["ours"] == "pd0 bulk decode (auvlink)"
        if "dolfyn" not in notes:  # the dolfyn venv was already built (smoke mode never builds it)
            dolfyn = [p for p in decode["peers"] if p["peer"].startswith("dolfyn")]
            assert len(dolfyn) == 2 and min(p["ratio"] for p in dolfyn) > 1.0


def test_every_stability_case_holds(smoke_run: Run) -> None:
    _, results, _, _ = smoke_run
    stab = results["stages"]["stability"]
    failed = [c for c in stab["stability"] if not c["ok"]]
    assert not failed, "\n".join(f"{c['case']}: {c['detail']}" for c in failed)
    assert stab["cases"] >= 40
    nav = stab["dead_reckoning"]
    assert nav["along_bias_end_m"] == pytest.approx(nav["along_bias_end_expected_m"], rel=0.1)


def test_report_shows_every_plot(smoke_run: Run) -> None:
    out, results, _, _ = smoke_run
    page = (out / "bench.html").read_text()
    plots = out / "plots"
    expected = {"peers.png"}
    for stage, res in results["stages"].items():
        assert f'id="{_slug(stage)}"' in page
        for knob in {r["knob"] for r in res.get("tradeoffs", [])}:
            expected.add(f"tradeoff_{_slug(stage)}_{_slug(knob)}.png")
        for spec in res.get("plots", []):
            expected.add(f"curve_{_slug(stage)}_{_slug(spec['title'])[:60]}.png")
    found = {p.name for p in plots.glob("*.png")}
    assert expected <= found, f"missing plots: {sorted(expected - found)}"
    for name in found:
        assert f'data-file="plots/{name}"' in page
        assert_plot_drawn(plots / name)  # a PNG with its data drawn, not just axes
    assert "Numerical stability" in page and "Peers in the same run" in page
