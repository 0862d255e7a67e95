"""One config model: the four TOML files validated by pydantic with one error form, their published
JSON Schemas, options nothing reads, URL keys, and a log whose stored configuration is damaged."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

import jsonschema
import numpy as np
import pytest
from scenes import obj, scene_toml

from auvlink.cli.schemas import schema_texts
from auvlink.config import VehicleConfig, config_from_metadata, load_config, loads_config
from auvlink.errors import ConfigError, TransportInitError
from auvlink.sim.scene import default_scene_text
from auvlink.sim.settings import loads_settings
from auvlink.transports.serial_port import parse_serial_url
from classify.training.config import DEFAULT_CONFIG, load_train_settings

ROOT = Path(__file__).resolve().parents[1]
SCHEMAS = ROOT / "docs" / "schemas"
DEV = '[[devices]]\nname = "dvl"\nformat = "pd0"\nurl = "/dev/ttyUSB0?baudrate=115200"\n'


def _err(fn: Any, *args: Any) -> ConfigError:
    with pytest.raises(ConfigError) as err:
        fn(*args)
    return err.value


# -- one error form in every file ---------------------------------------------------------------
def test_vehicle_unknown_key_names_the_allowed_keys() -> None:
    e = _err(loads_config, DEV.replace("format", "fromat"))
    assert str(e) == ("config key 'devices[0].fromat': unknown key "
                      "(allowed here: format, mounting, name, options, url)")


def test_settings_unknown_key_and_bound(tmp_path: Path) -> None:
    e = _err(loads_settings, "[sensors]\ngyro_hzz = 100.0\n")
    assert e.key == "sensors.gyro_hzz" and e.problem == "unknown key" and "gyro_hz" in e.fix
    e = _err(loads_settings, "[noise.dvl]\nvelocity_sigmaa = 0.1\n")
    assert e.key == "noise.dvl.velocity_sigmaa" and "velocity_sigma" in e.fix
    e = _err(loads_settings, "[sensors]\ngyro_hz = 1e9\n")
    assert e.key == "sensors.gyro_hz" and "out of range" in e.problem and "5000.0" in e.fix
    e = _err(loads_settings, '[sensors]\npressure = "bar"\n')
    assert e.key == "sensors.pressure" and "paro" in e.fix


def test_classify_unknown_keys_and_bounds(tmp_path: Path) -> None:
    for text, key, hint in [("[train]\nepochz = 3\n", "train.epochz", "epochs"),
                            ("[synthesis]\nrays_per_bean = 3\n", "synthesis.rays_per_bean", "rays_per_beam"),
                            ("[train.augment]\nyawn = true\n", "train.augment.yawn", "yaw"),
                            ("[bogus]\n", "bogus", "quick, surveys, synthesis, train"),
                            ("[synthesis]\nn_points = 100000000\n", "synthesis.n_points", "16384")]:
        p = tmp_path / "t.toml"
        p.write_text(text)
        e = _err(load_train_settings, p)
        assert e.key == key and hint in e.fix, str(e)


# -- options nothing reads, files that do not exist, URL keys ------------------------------------
@pytest.mark.parametrize("extra,key,words", [
    ("options = { frobnicate = 3 }\n", "devices[0].options.frobnicate", "unknown option"),
    ('[can]\ndbc = "/nonexistent.dbc"\n', "can.dbc", "/nonexistent.dbc"),
    ('[can]\nbitrate = "fast"\n', "can.bitrate", "unknown key"),
])
def test_options_nothing_reads_are_rejected(extra: str, key: str, words: str) -> None:
    e = _err(loads_config, DEV + extra)
    assert e.key == key and words in str(e)


def test_dbc_is_found_next_to_the_config_and_in_the_package(tmp_path: Path) -> None:
    (tmp_path / "mine.dbc").write_text("VERSION \"\"\n")
    cfg = tmp_path / "v.toml"
    cfg.write_text(DEV + '[can]\ndbc = "mine.dbc"\n')
    assert load_config(cfg).can is not None
    assert loads_config(DEV + '[can]\ndbc = "auvlink_nav.dbc"\n').can is not None


@pytest.mark.parametrize("url,key", [
    ("loop://?frob=1", "frob"), ("/dev/ttyUSB0?baud=9600", "baud"), ("socket://127.0.0.1:4001?frob=2", "frob"),
    ("can://virtual/nav?bitrate=fast", "bitrate"),
])
def test_url_keys_are_named(url: str, key: str) -> None:
    e = _err(loads_config, DEV.replace("/dev/ttyUSB0?baudrate=115200", url))
    assert e.key == "devices[0].url" and repr(key) in e.problem


def test_loop_url_names_the_key() -> None:
    with pytest.raises(TransportInitError, match=r"unknown URL key 'frob'.*allowed for loop: .*logging"):
        parse_serial_url("loop://?frob=1")
    assert parse_serial_url("loop://?logging=debug&baudrate=9600") == ("loop://?logging=debug", {"baudrate": 9600})


def test_site_in_the_vehicle_config() -> None:
    cfg = loads_config(DEV + "[site]\nlatitude = 36.0412\nlongitude = 129.3915\n")
    assert cfg.site is not None and cfg.to_dict()["site"] == {"latitude": 36.0412, "longitude": 129.3915}
    e = _err(loads_config, DEV + "[site]\nlatitude = 95.0\n")
    assert e.key == "site.latitude" and "[-90.0, 90.0]" in e.fix


def test_config_round_trips_through_the_log_form() -> None:
    cfg = load_config(ROOT / "examples" / "virtual_ports.toml")
    again = config_from_metadata({"vehicle_config": {"config": json.loads(json.dumps(cfg.to_dict()))}})
    assert again.devices == cfg.devices and again.sonar == cfg.sonar and again.can == cfg.can


# -- the published schemas -------------------------------------------------------------------------
def test_committed_schemas_equal_the_generated_ones() -> None:
    """``python scripts/gen_schemas.py`` rewrites docs/schemas/ when a model changes."""
    texts = schema_texts()
    assert sorted(p.name for p in SCHEMAS.glob("*.schema.json")) == sorted(texts)
    for name, text in texts.items():
        assert (SCHEMAS / name).read_text(encoding="utf-8") == text, f"{name} is stale: run scripts/gen_schemas.py"


def test_shipped_files_validate_against_the_schemas() -> None:
    def check(schema: str, doc: dict[str, Any]) -> None:
        jsonschema.validate(doc, json.loads((SCHEMAS / schema).read_text()))

    for name in ("virtual_ports.toml", "hardware.toml"):
        check("vehicle.schema.json", tomllib.loads((ROOT / "examples" / name).read_text()))
    check("scene.schema.json", tomllib.loads(default_scene_text()))
    check("train.schema.json", tomllib.loads(DEFAULT_CONFIG.read_text()))
    with pytest.raises(jsonschema.ValidationError):
        check("scene.schema.json", {**tomllib.loads(default_scene_text()), "bogus": {}})


# -- a log whose stored vehicle configuration is damaged -------------------------------------------
SCENE = scene_toml(seed=3, seabed={"depth": 12.0, "roughness": None}, objects=[obj("box", 8.0, 0.0)],
                   survey={"line_length": 14.0, "line_spacing": 3.0, "altitude": 4.0, "speed": 1.0},
                   sonar={"fps": 5.0, "lever_arm": [0.6, 0.0, 0.2]}, noise={"enabled": False})


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, VehicleConfig]:
    from auvlink.sim.mission import simulate_to_log
    from auvlink.sim.scene import loads_scene
    from logs_format import MissionLogReader, MissionLogWriter

    d = tmp_path_factory.mktemp("meta")
    good, bad = d / "good.mcap", d / "bad.mcap"
    simulate_to_log(loads_scene(SCENE), good, progress=False, workers=1)
    with MissionLogReader(good) as reader:
        stored = config_from_metadata(reader.metadata(decode_json=True))
        with MissionLogWriter(bad) as w:
            w.add_metadata("vehicle_config", {"source": "x", "toml": "",
                                              "config": {"devices": "abc", "sonar": {"tilt_deg": "abc"}}})
            for m in reader.messages():
                if m.format is not None:
                    w(m.channel, m.format, m.log_time_ns, m.data,
                      m.publish_time_ns if m.publish_time_ns != m.log_time_ns else None)
    return good, bad, stored


@pytest.mark.slow
def test_bad_metadata_replays_its_sensor_data_with_one_warning(
        logs: tuple[Path, Path, VehicleConfig], capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from auvlink.pipeline.process import run_log

    good, bad, stored = logs
    ref = run_log(good, classify=False, progress=False)
    capsys.readouterr()
    fallback = run_log(bad, classify=False, progress=False)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "warning" in err[0] and "'devices'" in err[0] and "--config" in err[0]
    assert fallback.recon_stats["frames_processed"] == ref.recon_stats["frames_processed"] > 0
    cfg = tmp_path / "vehicle.toml"
    cfg.write_text(stored.text)
    given = run_log(bad, classify=False, progress=False, config=load_config(cfg))
    assert capsys.readouterr().err == ""
    assert given.recon_stats == ref.recon_stats
    assert given.setup.sonar_mounting == stored.device("sonar").mounting != fallback.setup.sonar_mounting
    assert np.array_equal(given.track, ref.track) and not np.array_equal(fallback.track, ref.track)
    assert [d.position_ned for d in given.detections] == [d.position_ned for d in ref.detections]


@pytest.mark.slow
def test_replay_cli_takes_config(logs: tuple[Path, Path, VehicleConfig], tmp_path: Path,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    from auvlink.cli import main

    _, bad, stored = logs
    cfg = tmp_path / "vehicle.toml"
    cfg.write_text(stored.text)
    rc = main(["replay", str(bad), "--out", str(tmp_path / "out"), "--config", str(cfg), "--no-classify",
               "--no-report", "--quiet"])
    assert rc == 0 and "warning" not in capsys.readouterr().err
    assert (tmp_path / "out" / "detections.jsonl").is_file()


# -- sizes across the scene and its settings; one Mounting kept whole ------------------------------
def test_samples_per_stream_are_bounded() -> None:
    from auvlink.sim.scene import loads_scene
    from auvlink.sim.settings import check_budget

    text = SCENE.replace("lines = 1", "lines = 200").replace("line_length = 14.0", "line_length = 200.0")
    scene = loads_scene(text)  # 200 x 200 m at 1 m/s: about 11.4 h, within the 12 h limit
    check_budget(scene, loads_settings(text))
    e = _err(check_budget, scene, loads_settings(text + "[sensors]\ntruth_hz = 5000.0\n"))
    assert e.key == "sensors.truth_hz" and "20000000" in e.problem


def test_mission_setup_keeps_every_mounting() -> None:
    from scipy.spatial.transform import Rotation

    from auvlink.pipeline.setup import MissionSetup, nav_config, sonar_geometry
    from recon.frames import RDI_SWAP, attitude

    cfg = loads_config(DEV.replace("\n", "\nmounting = { xyz = [0.4, 0.1, 0.25], rpy_deg = [1.0, 2.0, 45.0] }\n", 1)
                       + '[[devices]]\nname = "son"\nformat = "didson"\nurl = "tcp://127.0.0.1:5600"\n'
                       'mounting = { xyz = [1.2, 0.0, 0.1], rpy_deg = [0.0, 0.0, 10.0] }\n'
                       '[sonar]\ndevice = "son"\ntilt_deg = 25.0\nwindow_start = 2.0\nwindow_length = 8.0\n')
    setup = MissionSetup.from_config(cfg)
    assert setup.dvl_mounting.rpy_deg == (1.0, 2.0, 45.0) and setup.sonar.tilt_deg == 25.0
    nav = nav_config(setup)
    want = attitude(np.radians(45.0), np.radians(2.0), np.radians(1.0)) * Rotation.from_matrix(RDI_SWAP)
    assert np.allclose(nav.dvl_mounting.rotation.as_matrix(), want.as_matrix(), atol=1e-12)
    assert nav.dvl_mounting.lever_arm == (0.4, 0.1, 0.25)
    g = sonar_geometry(setup)
    assert g.lever_arm == (1.2, 0.0, 0.1) and (g.window_start, g.window_length) == (2.0, 8.0)
    boresight = g.directions_body(0.0, np.array([0.0]))[0]  # yawed 10 deg to starboard, tilted 25 deg down
    assert np.allclose(boresight, [np.cos(np.radians(25)) * np.cos(np.radians(10)),
                                   np.cos(np.radians(25)) * np.sin(np.radians(10)), np.sin(np.radians(25))])
