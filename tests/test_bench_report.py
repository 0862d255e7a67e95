"""The benchmark report: Pareto fronts, plots and tables from a results.json structure (no stage runs)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from image_checks import assert_plot_drawn

from auvlink.cli import main
from auvlink.cli.bench import STAGES, benchmarks_dir, render_report
from auvlink.errors import AuvlinkError

sys.path.insert(0, str(benchmarks_dir()))
import report


def test_pareto_front_marks_only_non_dominated_settings() -> None:
    pts = [(1.0, 5.0), (2.0, 3.0), (3.0, 3.5), (4.0, 1.0), (2.0, 3.0), (0.5, 9.0), (5.0, 1.0)]
    assert report.pareto_front(pts) == [True, True, False, True, True, True, False]
    assert report.pareto_front([(1.0, 1.0)]) == [True]
    assert report.pareto_front([]) == []


def _results() -> dict:
    trade = [{"knob": "rays per beam K", "setting": k, "time_s": t, "time_unit": "frame", "error": e,
              "error_name": "highlight error [m]", "default": k == 32}
             for k, t, e in ((8, 3e-4, 0.08), (16, 4e-4, 0.016), (32, 5e-4, 0.006), (64, 7e-4, 0.007))]
    return {"mode": "smoke", "command": "auvlink bench --smoke", "machine": {"cpu": "test", "cores": 2},
            "stages": {
                "sim": {"wall_s": 1.0, "fps": 900.5, "tradeoffs": trade, "rows": [{"K": 8, "fps": 1.0}],
                        "peers": [{"what": "culling", "ours": "rays", "ours_s": 1e-3, "peer": "none",
                                   "peer_s": 2e-3, "ratio": 2.0}]},
                "stability": {"wall_s": 2.0, "stability": [{"case": "a <b>", "ok": True, "detail": "fine"},
                                                           {"case": "b", "ok": False, "detail": "broke"}],
                              "plots": [{"title": "growth", "x": [1, 10, 100], "loglog": True,
                                         "series": {"rms": [1, 3, 10], "theory": [1, 3.2, None]}}]},
            }}


@pytest.mark.slow
def test_render_writes_every_plot_and_table(tmp_path: Path) -> None:
    html_path = report.render(_results(), tmp_path)
    page = html_path.read_text()
    pngs = sorted(p.name for p in (tmp_path / "plots").glob("*.png"))
    assert pngs == ["curve_stability_growth.png", "peers.png", "tradeoff_sim_rays_per_beam_k.png"]
    for name in pngs:
        assert f'data-file="plots/{name}"' in page
        assert_plot_drawn(tmp_path / "plots" / name)  # a PNG with its data drawn in colour
    assert page.count("data:image/png;base64,") == 3
    assert 'id="sim"' in page and 'id="stability"' in page
    assert "a &lt;b&gt;" in page and '<tr class="fail"><td>b</td>' in page
    # K=64 is slower and less accurate than K=32: off the front; the others are on it
    rows = page.split("Run time against error")[1]
    assert rows.count("<td>yes</td></tr>") == 3
    assert "auvlink bench --smoke" in page
    # the default K=32 is reported as a Pareto point
    assert report.default_points(_results()["stages"]) == [
        {"stage": "sim", "knob": "rays per beam K", "default": 32, "time_s": 5e-4, "time_unit": "frame",
         "error": 0.006, "error_name": "highlight error [m]", "on_front": True}]
    assert "Defaults against the Pareto front" in page


@pytest.mark.slow
def test_cli_report_only_rerenders(tmp_path: Path) -> None:
    (tmp_path / "results.json").write_text(json.dumps(_results()))
    assert main(["bench", "--out", str(tmp_path), "--report-only"]) == 0
    assert (tmp_path / "bench.html").is_file()
    assert render_report(tmp_path) == tmp_path / "bench.html"
    assert "stability" in STAGES


@pytest.mark.slow
def test_cli_rejects_unknown_stage(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-c", "import sys; from auvlink.cli import main; "
                           "sys.exit(main(sys.argv[1:]))", "bench", "nosuch", "--out", str(tmp_path)],
                          capture_output=True, text=True)
    assert proc.returncode == 1
    assert "unknown benchmark stage 'nosuch'" in proc.stderr


def test_missing_results_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(AuvlinkError, match=r"results\.json"):
        render_report(tmp_path)


def test_a_failing_stage_is_recorded_and_the_others_still_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    import types

    import auvlink.cli.bench as bench

    def fake(stage: str) -> types.ModuleType:
        mod = types.ModuleType(stage)

        def run(quick: bool, out_dir: Path) -> dict:
            if stage == "decode":
                raise RuntimeError("broken on purpose")
            assert os.environ.get("AUVLINK_BENCH_SMOKE") == "1" and quick
            return {"tradeoffs": [{"knob": "k", "setting": s, "time_s": t, "time_unit": "frame", "error": e,
                                   "error_name": "e [m]", "default": s == 2} for s, t, e in ((1, 1.0, 2.0),
                                                                                            (2, 2.0, 1.0))]}

        mod.run = run  # type: ignore[attr-defined]
        return mod

    monkeypatch.setenv("AUVLINK_BENCH_SMOKE", "0")
    monkeypatch.setattr(bench, "load_stage", fake)
    assert main(["bench", "decode", "sim", "--smoke", "--out", str(tmp_path)]) == 1
    res = json.loads((tmp_path / "results.json").read_text())
    assert res["stages"]["decode"]["error"] == "RuntimeError: broken on purpose"
    assert res["stages"]["sim"]["mode"] == "smoke" and res["stages"]["sim"]["wall_s"] >= 0
    assert "failed stage(s): decode" in capsys.readouterr().err
    page = (tmp_path / "bench.html").read_text()
    assert "stage failed: RuntimeError: broken on purpose" in page
    assert (tmp_path / "plots" / "tradeoff_sim_k.png").is_file()
    # a later run of one stage keeps the other stages' results
    assert main(["bench", "sim", "--smoke", "--out", str(tmp_path)]) == 0
    res2 = json.loads((tmp_path / "results.json").read_text())
    assert set(res2["stages"]) == {"decode", "sim"} and res2["command"].startswith("auvlink bench sim --out")
    assert res2["stages"]["decode"]["error"] == "RuntimeError: broken on purpose"
