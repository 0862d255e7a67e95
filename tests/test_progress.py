"""Progress bars show only on a terminal: a command whose stderr is a file gets no carriage-return lines."""

from __future__ import annotations

import io
import os
import subprocess
import sys
from pathlib import Path

import pytest
from scenes import obj, scene_toml

from auvlink.progress import on_terminal, progress_bar

ROOT = Path(__file__).resolve().parents[1]
TINY = scene_toml(seabed={"depth": 15.0, "roughness": None, "slope_deg": None, "slope_azimuth_deg": None},
                  objects=[obj("sphere", 8.0, 0.3)],
                  survey={"line_length": 12.0, "line_spacing": 3.0, "lines": 2, "altitude": 4.0},
                  sonar={"window_length": 8.0, "fps": 2.0})


@pytest.mark.slow
def test_sim_with_stderr_in_a_file_writes_no_progress_bar(tmp_path: Path) -> None:
    scene = tmp_path / "tiny.toml"
    scene.write_text(TINY)
    err_path = tmp_path / "stderr.txt"
    with err_path.open("w") as err:
        proc = subprocess.run(
            [sys.executable, "-c", "import sys; from auvlink.cli import main; sys.exit(main(sys.argv[1:]))",
             "sim", "--scene", str(scene), "--out", str(tmp_path / "m.mcap"), "--duration", "3", "--no-noise"],
            stdout=subprocess.PIPE, stderr=err, text=True, timeout=120)
    text = err_path.read_text()
    assert proc.returncode == 0, text[-2000:]
    assert "\r" not in text and "frame/s" not in text and "%|" not in text, text[:500]


def test_bar_shows_on_a_terminal_only() -> None:
    sink = io.StringIO()
    with progress_bar(range(3), file=sink, desc="x") as bar:
        assert bar.disable
        list(bar)
    assert sink.getvalue() == "" and not on_terminal(sink)
    master, slave = os.openpty()
    try:
        with os.fdopen(slave, "w") as tty:
            assert on_terminal(tty)
            with progress_bar(range(3), file=tty, desc="x") as bar:
                assert not bar.disable
            with progress_bar(range(3), file=tty, enabled=False) as bar:
                assert bar.disable
    finally:
        os.close(master)


def test_every_progress_bar_goes_through_the_helper() -> None:
    """No module but auvlink/progress.py makes a tqdm bar itself."""
    offenders = []
    for package in ("auvlink", "classify", "recon", "logs_format"):
        for path in (ROOT / package).rglob("*.py"):
            if path.name != "progress.py" and "tqdm(" in path.read_text().replace("# tqdm(", ""):
                offenders.append(str(path.relative_to(ROOT)))
    assert offenders == []
