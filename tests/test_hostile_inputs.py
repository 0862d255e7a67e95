"""Hostile inputs of issue 34's last pass: every case that failed before its fix (traceback, silent acceptance,
unbounded memory or processes, a replaced file, an error line that echoes the whole input).

The harness that found them runs every case through the CLI (``/work/notes/hostile/harness.py``); each case here
runs the same input through the real entry point (``auvlink.cli.main`` or the public function) and checks the one
error line names the option or key, and that nothing was written or replaced.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from auvlink.cli import main
from auvlink.config import loads_config
from auvlink.errors import AuvlinkError, ConfigError
from auvlink.sim.scene import default_scene_text, loads_scene

ROOT = Path(__file__).resolve().parents[1]
VIRTUAL_PORTS = (ROOT / "examples" / "virtual_ports.toml").read_text()
TRAIN_DEFAULT = (ROOT / "classify" / "data" / "train_default.toml").read_text()


def _cli_error(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """The one error line of a refused command (exit 1 or 2, no traceback)."""
    code = main(argv)
    err = capsys.readouterr().err
    assert code in (1, 2), err
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("auvlink: error: "), err
    return lines[0]


# -- vehicle config: transport URLs ------------------------------------------------------------------------------
@pytest.mark.parametrize(("url", "says"), [
    ("tcp://127.0.0.1:0", "port 0"),
    ("tcp://127.0.0.1:70000", "Port out of range"),
    ("tcp://127.0.0.1:-1", "-1"),
    ("tcp://127.0.0.1:http", "http"),
    ("tcp://:5600", "no host"),
    ("tcp://[::1:5600", "cannot parse"),
    ("/tmp/auvlink/dvl?baudrate=-9600", "baudrate -9600"),
    ("/tmp/auvlink/dvl?baudrate=1000000000000", "baudrate 1000000000000"),
])
def test_vehicle_config_refuses_a_bad_url(url: str, says: str) -> None:
    text = VIRTUAL_PORTS.replace("/tmp/auvlink/dvl?baudrate=115200", url, 1)
    with pytest.raises(ConfigError) as info:
        loads_config(text)
    assert info.value.key == "devices[0].url"
    assert says in str(info.value)


@pytest.mark.parametrize("url", ["tcp-listen://127.0.0.1:0", "tcp://127.0.0.1:65535",
                                 "/tmp/auvlink/dvl?baudrate=12000000"])
def test_vehicle_config_keeps_edge_urls_that_work(url: str) -> None:
    config = loads_config(VIRTUAL_PORTS.replace("/tmp/auvlink/dvl?baudrate=115200", url, 1))
    assert config.devices[0].url == url


# -- scene: a list past its bound is named, not printed -----------------------------------------------------------
def test_too_many_objects_is_one_short_line() -> None:
    objects = "".join(f'[[objects]]\nclass = "box"\nposition = [{i * 0.01}, 0.0]\n\n' for i in range(10_001))
    text = default_scene_text().replace("[survey]", objects + "[survey]", 1)
    with pytest.raises(ConfigError) as info:
        loads_scene(text)
    assert info.value.key == "objects"
    assert "too many" in str(info.value) and "10000" in str(info.value)
    assert len(str(info.value)) < 200


def test_a_long_vector_is_quoted_in_part() -> None:
    text = default_scene_text().replace("origin = [0.0, 0.0]", "origin = [" + ", ".join(["1.0"] * 500) + "]", 1)
    with pytest.raises(ConfigError) as info:
        loads_scene(text)
    assert "expected a list of 2 numbers" in str(info.value)
    assert len(str(info.value)) < 200


# -- sim options ---------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("option", "value", "says"), [
    ("--duration", "1e12", "the duration"),
    ("--workers", "0", "workers"),
    ("--workers", "10000", "workers"),
])
def test_sim_refuses_unbounded_options(option: str, value: str, says: str, tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    args = ["sim", "--out", str(tmp_path / "o.mcap"), "--quiet", option, value]
    if option != "--duration":
        args += ["--duration", "1"]
    line = _cli_error(args, capsys)
    assert says in line
    assert not (tmp_path / "o.mcap").exists()


# -- train and eval options, the training settings ----------------------------------------------------------------
@pytest.mark.parametrize(("argv", "says"), [
    (["--calibrate-surveys", "1000000000"], "--calibrate-surveys"),
    (["--calibrate-surveys", "1", "--calibrate-seed", "-1"], "--calibrate-seed"),
    (["--calibrate-surveys", "1", "--workers", "100000"], "--workers"),
    (["--calibrate-surveys", "1", "--workers", "-3"], "--workers"),
])
def test_train_refuses_survey_options_out_of_range(argv: list[str], says: str, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    line = _cli_error(["train", "--out", str(tmp_path / "m.pt"), *argv], capsys)
    assert says in line
    assert not (tmp_path / "m.pt").exists()


@pytest.mark.parametrize(("old", "new", "key"), [
    ("width = 0.25", "width = 64.0", "train.width"),
    ("n_points = 256", "n_points = 1000000", "train.n_points"),
    ("members = 4", "members = -1", "train.members"),
    ("members = 4", "members = 1000000", "train.members"),
    ("heading_step_deg = 20", "heading_step_deg = 1e-9", "synthesis.heading_step_deg"),
])
def test_training_settings_bounded_as_the_checkpoint(old: str, new: str, key: str, tmp_path: Path) -> None:
    from classify.training.config import load_train_settings

    path = tmp_path / "t.toml"
    assert "\n" + old in TRAIN_DEFAULT
    path.write_text(TRAIN_DEFAULT.replace("\n" + old, "\n" + new, 1))  # the key, not a comment naming it
    with pytest.raises(ConfigError) as info:
        load_train_settings(path)
    assert info.value.key == key


@pytest.mark.parametrize(("option", "kwargs"), [
    ("--epochs", {"epochs": -1}), ("--epochs", {"epochs": 0}), ("--threads", {"threads": 0}),
    ("--seed", {"seed": -1}), ("--surveys", {"surveys": -1}), ("--surveys", {"surveys": 10_001}),
])
def test_training_overrides_checked(option: str, kwargs: dict[str, int]) -> None:
    from classify.training.config import load_train_settings, with_overrides

    with pytest.raises(AuvlinkError, match=option):
        with_overrides(load_train_settings(), **kwargs)


# -- bench: a results.json that is not a benchmark's -------------------------------------------------------------
def test_bench_report_only_on_a_foreign_results_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "results.json").write_text("[]")
    line = _cli_error(["bench", "--report-only", "--out", str(tmp_path)], capsys)
    assert "not a benchmark results file" in line


def test_bench_never_replaces_a_foreign_results_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mine = tmp_path / "results.json"
    mine.write_text(json.dumps([1, 2]))
    line = _cli_error(["bench", "decode", "--smoke", "--out", str(tmp_path)], capsys)
    assert "--out" in line
    assert mine.read_text() == "[1, 2]"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.json"]


def test_bench_out_is_a_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "f"
    f.write_text("keep")
    assert "--out" in _cli_error(["bench", "decode", "--smoke", "--out", str(f)], capsys)
    assert f.read_text() == "keep"


# -- replay pacing -------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("speed", ["nan", "inf"])
def test_replay_speed_must_be_finite(speed: str, small_mission_log: Path, tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    line = _cli_error(["replay", str(small_mission_log), "--out", str(tmp_path / "r"), "--speed", speed,
                       "--no-classify", "--quiet"], capsys)
    assert "--speed" in line
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize(("kwargs", "says"), [({"speed": math.nan}, "speed"), ({"speed": math.inf}, "speed"),
                                              ({"buffer": 0}, "buffer"), ({"buffer": -5}, "buffer")])
def test_api_replay_checks_its_arguments(kwargs: dict[str, float], says: str, small_mission_log: Path) -> None:
    import auvlink

    with pytest.raises(AuvlinkError, match=says):
        auvlink.replay(small_mission_log, classify=False, **kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize(("argv", "says"), [
    (["--surveys", "1000000000"], "--surveys"),
    (["--surveys", "1", "--seed", "-5"], "--seed"),
    (["--surveys", "1", "--seed", str(2**70)], "--seed"),
    (["--surveys", "1", "--workers", "100000"], "--workers"),
    (["--seed", "-5"], "--seed"),
])
def test_eval_refuses_survey_options_out_of_range(argv: list[str], says: str, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    line = _cli_error(["eval", "--out", str(tmp_path / "e"), *argv], capsys)
    assert says in line
    assert not (tmp_path / "e").exists()


# -- files that are not what they should be ------------------------------------------------------------------------
@pytest.mark.parametrize(("content", "says"), [
    (bytes(range(128, 256)) * 40, "not UTF-8"),
    (b"seed = " + b"[" * 100_000 + b"]" * 100_000, "nested too deeply"),
])
def test_scene_file_that_is_not_toml_text(content: bytes, says: str, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    scene = tmp_path / "s.toml"
    scene.write_bytes(content)
    assert says in _cli_error(["sim", "--scene", str(scene), "--out", str(tmp_path / "o.mcap"), "--quiet"], capsys)


def test_sim_seed_beyond_63_bits(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    line = _cli_error(["sim", "--out", str(tmp_path / "o.mcap"), "--duration", "1", "--quiet", "--seed", str(2**80)],
                      capsys)
    assert "seed" in line
    assert not (tmp_path / "o.mcap").exists()


# -- log tools and decode: options and inputs that are not what they should be -------------------------------------
@pytest.mark.parametrize("rate", ["nan", "inf", "1e-300", "1e300", "0", "-5"])
def test_log_import_rate_in_range(rate: str, shared_data: Path, tmp_path: Path,
                                  capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "o.mcap"
    line = _cli_error(["log", "import", str(shared_data / "rdi" / "adcp_auv_3.pd0"), "--format", "pd0",
                       "--rate", rate, "--out", str(out)], capsys)
    assert "--rate" in line
    assert not out.exists()


@pytest.mark.parametrize(("argv", "says"), [
    (["info", "{log}", "--gap-factor", "-1"], "--gap-factor"),
    (["info", "{log}", "--gap-factor", "nan"], "--gap-factor"),
    (["export", "{log}", "--out", "{tmp}/e", "--max-sonar", "-1"], "--max-sonar"),
])
def test_log_options_in_range(argv: list[str], says: str, small_mission_log: Path, tmp_path: Path,
                              capsys: pytest.CaptureFixture[str]) -> None:
    args = [a.format(log=small_mission_log, tmp=tmp_path) for a in argv]
    assert says in _cli_error(["log", *args], capsys)
    assert not (tmp_path / "e").exists()


@pytest.mark.parametrize("kind", ["folder", "fifo"])
@pytest.mark.parametrize("argv", [["decode", "-f", "nmea", "{p}"], ["log", "info", "{p}"],
                                  ["log", "export", "{p}", "--out", "{tmp}/e"],
                                  ["log", "import", "{p}", "--format", "nmea", "--out", "{tmp}/o.mcap"]])
def test_an_input_that_is_not_a_regular_file(kind: str, argv: list[str], tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """A folder or a FIFO is refused at once (a FIFO nobody writes to blocked ``log info`` for ever)."""
    import os

    p = tmp_path / "input"
    if kind == "folder":
        p.mkdir()
    else:
        os.mkfifo(p)
    line = _cli_error([a.format(p=p, tmp=tmp_path) for a in argv], capsys)
    assert "not a regular file" in line


@pytest.mark.parametrize(("old", "new", "key", "says"), [
    ('mode = "scan"', 'mode = "nope"', "synthesis.mode", "paper"),
    ('z_ref = "seabed"', 'z_ref = "seabd"', "synthesis.z_ref", "seabed"),
    ('detect = "energy"', 'detect = "energyy"', "synthesis.detect", "energy"),
    ("tilts_deg = [20.0, 28.3333, 36.6667, 45.0]", "tilts_deg = []", "synthesis.tilts_deg", "at least one"),
    ("noise_fraction = [0.0, 0.1]", "noise_fraction = [-1.0, -2.0]", "synthesis.noise_fraction", "[0.0, 1.0]"),
    ("noise_fraction = [0.0, 0.1]", "noise_fraction = [0.5, 0.1]", "synthesis.noise_fraction", "smaller value first"),
    ("fused_passes = [2, 3]", "fused_passes = [0, 1000000]", "synthesis.fused_passes", "[1, 10]"),
    ("clutter_lines = [2, 3]", "clutter_lines = [-1, 1000000]", "synthesis.clutter_lines", "[1, 100]"),
    ("scale = [0.95, 1.05]", "scale = [0.0, 1e300]", "train.augment.scale", "(0.0, 10.0]"),
    ("jitter_sigma = 0.01", "jitter_sigma = -1.0", "train.augment.jitter_sigma", "[0.0, 10.0]"),
])
def test_training_words_and_ranges_checked(old: str, new: str, key: str, says: str, tmp_path: Path) -> None:
    """A misspelt word silently trained the other mode; a reversed or negative range was taken as written."""
    from classify.training.config import load_train_settings

    path = tmp_path / "t.toml"
    assert "\n" + old in TRAIN_DEFAULT
    path.write_text(TRAIN_DEFAULT.replace("\n" + old, "\n" + new, 1))
    with pytest.raises(ConfigError) as info:
        load_train_settings(path)
    assert info.value.key == key and says in str(info.value)


def test_log_export_unknown_channel(small_mission_log: Path, tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    """A misspelt --channels exported nothing of it (exit 0, navigation.csv alone)."""
    line = _cli_error(["log", "export", str(small_mission_log), "--out", str(tmp_path / "e"), "--channels", "dvll"],
                      capsys)
    assert "'dvll'" in line and "dvl" in line.partition("its channels:")[2]
    assert not (tmp_path / "e").exists()
