"""Simulated mission logs: every stream decodes through the real drivers, values match the truth, same seed
same bytes, ground truth stored."""

from __future__ import annotations

import io
import math
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scenes import obj, scene_toml
from scipy.spatial.transform import Rotation

from auvlink.cli import main
from auvlink.codecs import keller
from auvlink.sim.mission import SimResult, simulate_to_log
from auvlink.sim.scene import CLASSES, load_scene
from logs_format import MissionLogReader, Replay
from recon.frames import bottom_track_to_vehicle, rdi_ship_to_body
from recon.nav import pressure_to_depth

# two short lines over a sphere and a box on a 15 m seabed sloping 2 deg, across a current
TINY = scene_toml(seabed={"depth": 15.0, "slope_deg": 2.0, "slope_azimuth_deg": 45.0},
                  objects=[obj("sphere", 8.0, 0.3), obj("box", 4.0, 3.0, 30.0)],
                  survey={"line_length": 12.0, "line_spacing": 3.0, "lines": 2, "altitude": 4.0},
                  sonar={"window_length": 8.0, "fps": 2.0}, vehicle={"current": [0.1, 0.05]})
START_NS = 1_767_225_600 * 10**9  # 2026-01-01T00:00:00Z


@pytest.fixture(scope="module")
def scene_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    p = tmp_path_factory.mktemp("scene") / "tiny.toml"
    p.write_text(TINY)
    return p


@pytest.fixture(scope="module")
def logs(scene_path: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, SimResult]]:
    d = tmp_path_factory.mktemp("logs")
    scene = load_scene(scene_path)
    out = {}
    for name, noise in (("noisy", None), ("exact", False)):
        path = d / f"{name}.mcap"
        out[name] = (path, simulate_to_log(scene, path, progress=False, noise=noise, workers=1))
    return out


def _decode(path: Path) -> tuple[dict[str, list[Any]], dict[str, Any], dict[str, Any], np.ndarray]:
    samples: dict[str, list[Any]] = defaultdict(list)
    with Replay(path) as rep:
        for s in rep.samples():
            samples[s.device].append(s)
        stats = rep.stats()
        meta = rep.reader.metadata(decode_json=True)
        truth = np.load(io.BytesIO(rep.reader.read_attachment("truth/trajectory.npy")))
    return samples, stats, meta, truth


def _t(samples: list[Any]) -> np.ndarray:
    return np.array([(s.t_host_ns - START_NS) * 1e-9 for s in samples])


def _interp(truth: np.ndarray, t: np.ndarray, name: str) -> np.ndarray:
    x = truth[name]
    if name in ("yaw",):
        return np.interp(t, truth["t"], np.unwrap(x))
    return np.interp(t, truth["t"], x)


def _dvl_check(samples: dict[str, list[Any]], meta: dict[str, Any], truth: np.ndarray) -> np.ndarray:
    """Residual of the DVL velocity after recon's frame conversion and lever-arm removal (m/s)."""
    dvl = samples["dvl"]
    t = _t(dvl)
    assert all(e.record.coordinate_system == "ship" for e in dvl)
    bt = np.array([e.record.bt_velocity_mps for e in dvl])
    good = np.isfinite(bt).all(axis=1)
    v_dvl = rdi_ship_to_body(bottom_track_to_vehicle(bt[good, :3]))
    lever = np.array(next(d for d in meta["vehicle_config"]["config"]["devices"]
                          if d["name"] == "dvl")["mounting"]["xyz"])
    w = np.stack([_interp(truth, t[good], k) for k in ("p", "q", "r")], axis=1)
    v = v_dvl - np.cross(w, lever)
    v_true = np.stack([_interp(truth, t[good], k) for k in ("u", "v", "w")], axis=1)
    return v - v_true


def test_every_stream_decodes_with_no_error(logs: dict[str, tuple[Path, SimResult]]) -> None:
    path, result = logs["noisy"]
    samples, stats, _, _ = _decode(path)
    assert set(stats) == {"dvl", "gyro", "pressure", "can", "sonar"}
    for name, st in stats.items():
        assert st["decode_errors"] == 0, name
        assert st["framer_dropped_bytes"] == 0 and st["framer_bad_checksums"] == 0, name
        assert st["samples"] == result.frames[name] > 0
    dur = result.duration_s
    assert result.frames["gyro"] == math.ceil(dur * 100) and result.frames["dvl"] == math.ceil(dur * 5)
    assert result.frames["sonar"] == math.ceil(dur * 2)
    frames = [s.record for s in samples["sonar"]]
    assert all(f.image.shape == (512, 96) and f.window_start_m == 1.0 and f.window_length_m == 8.0
               for f in frames)
    np.testing.assert_allclose(np.diff(_t(samples["sonar"])), 0.5, atol=1e-9)
    np.testing.assert_allclose([s.t_sensor for s in samples["sonar"]], _t(samples["sonar"]) + START_NS * 1e-9,
                               atol=1e-6)
    assert max(int(f.image.max()) for f in frames) > 0


def test_values_match_the_truth_within_the_noise(logs: dict[str, tuple[Path, SimResult]]) -> None:
    samples, _, meta, truth = _decode(logs["noisy"][0])
    resid = _dvl_check(samples, meta, truth)
    assert np.abs(resid).max() < 6 * 0.003 + 0.001 * 2.0
    assert 0.002 < resid.std() < 0.0045
    # pressure -> depth at the sensor (lever arm) against the truth: 0.01 % of 20 bar is about 2 cm
    p = samples["pressure"]
    t = _t(p)
    depth = pressure_to_depth([s.record.pressure_pa for s in p])
    rot = Rotation.from_euler("ZYX", np.stack([_interp(truth, t, k) for k in ("yaw", "pitch", "roll")], axis=1))
    true_depth = _interp(truth, t, "down") + rot.apply([-0.60, 0.0, 0.0])[:, 2]
    assert np.abs(depth - true_depth).std() < 0.03 and np.abs(depth - true_depth).max() < 0.12
    # gyro: the heading rate (q sin roll + r cos roll) / cos pitch integrates to the heading change
    g = samples["gyro"]
    tg = _t(g)
    rates = np.array([s.record.gyro for s in g])
    roll, pitch = _interp(truth, tg, "roll"), _interp(truth, tg, "pitch")
    psi_dot = (rates[:, 1] * np.sin(roll) + rates[:, 2] * np.cos(roll)) / np.cos(pitch)
    heading = np.concatenate([[0.0], np.cumsum(0.5 * (psi_dot[1:] + psi_dot[:-1]) * np.diff(tg))])
    change = _interp(truth, tg, "yaw") - _interp(truth, tg[:1], "yaw")
    assert abs(change[-1]) > 3.0
    assert np.abs(heading - change).max() < 0.01


def test_noise_free_values_are_exact_within_the_wire(logs: dict[str, tuple[Path, SimResult]]) -> None:
    samples, _, meta, truth = _decode(logs["exact"][0])
    resid = _dvl_check(samples, meta, truth)
    assert np.abs(resid).max() < 0.0005 + 1e-4  # mm/s on the wire, 50 Hz truth interpolated
    assert all(np.isfinite(s.record.bt_range_m).all() for s in samples["dvl"])
    can = defaultdict(list)
    for s in samples["can"]:
        can[s.record.name].append(s)
    depth = np.array([s.record.signals["depth"] for s in can["DEPTH"]])
    paro = pressure_to_depth([s.record.pressure_pa for s in samples["pressure"]])
    np.testing.assert_allclose(depth, paro, atol=0.0006)  # 1 mm on the CAN bus
    att = can["ATTITUDE"]
    heading = np.array([s.record.signals["heading"] for s in att])
    true = np.mod(_interp(truth, _t(att), "yaw"), 2 * math.pi)
    assert np.abs(np.angle(np.exp(1j * (heading - true)))).max() < 2e-4


def test_same_seed_same_bytes_other_seed_other_bytes(scene_path: Path, tmp_path: Path,
                                                     logs: dict[str, tuple[Path, SimResult]]) -> None:
    scene = load_scene(scene_path)
    again = tmp_path / "again.mcap"
    simulate_to_log(scene, again, progress=False, workers=2, block_s=1.5)
    assert again.read_bytes() == logs["noisy"][0].read_bytes()
    other = tmp_path / "other.mcap"
    simulate_to_log(scene, other, seed=12, progress=False, duration=5.0)
    short = tmp_path / "short.mcap"
    simulate_to_log(scene, short, seed=11, progress=False, duration=5.0)
    assert other.read_bytes() != short.read_bytes()


def test_ground_truth_is_in_the_log(logs: dict[str, tuple[Path, SimResult]]) -> None:
    path, result = logs["noisy"]
    with MissionLogReader(path) as log:
        meta = log.metadata(decode_json=True)
        gt = meta["ground_truth"]
        assert gt["scene_toml"] == TINY and gt["seed"] == 11 and gt["start_ns"] == START_NS
        assert [o["class"] for o in gt["objects"]] == ["sphere", "box"]
        assert all(o["class_index"] == CLASSES.index(o["class"]) for o in gt["objects"])
        names = {a.name for a in log.attachments()}
        assert {o["mesh"] for o in gt["objects"]} | {"truth/trajectory.npy"} <= names
        for o in gt["objects"]:
            ply = log.read_attachment(o["mesh"])
            head, _, body = ply.partition(b"end_header\n")
            n_v = int(head.split(b"element vertex ")[1].split(b"\n")[0])
            n_f = int(head.split(b"element face ")[1].split(b"\n")[0])
            assert len(body) == n_v * 24 + n_f * 13
            v = np.frombuffer(body[: n_v * 24], "<f8").reshape(-1, 3)
            np.testing.assert_allclose(v.min(axis=0), o["bbox_min_ned"])
        truth = np.load(io.BytesIO(log.read_attachment("truth/trajectory.npy")))
        assert np.diff(truth["t"]).max() <= 1 / 50 + 1e-12 and truth["t"][-1] > result.duration_s - 0.1
        poses = list(log.messages(["truth/pose"]))
        assert len(poses) == math.ceil(result.duration_s * 10) and poses[0].log_time_ns == START_NS
        assert gt["trajectory"]["rate_hz"] == 50.0 and len(truth) == math.ceil(result.duration_s * 50)
        assert meta["software"]["generator"] == "auvlink.sim"
        devices = {d["name"]: d["format"] for d in meta["vehicle_config"]["config"]["devices"]}
        assert devices == {"dvl": "pd0", "gyro": "dsp1760", "pressure": "paro", "can": "can", "sonar": "didson"}
        assert meta["vehicle_config"]["config"]["sonar"]["tilt_deg"] == 30.0


def test_keller_variant_and_cli(scene_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = tmp_path / "keller.toml"
    scene.write_text(TINY + '[sensors]\npressure = "keller"\n')
    out = tmp_path / "k.mcap"
    assert main(["sim", "--scene", str(scene), "--out", str(out), "--duration", "3", "--no-noise", "--quiet"]) == 0
    with Replay(out, channels=["pressure"]) as rep:
        recs = [s.record for s in rep.samples()]
        assert rep.stats()["pressure"]["decode_errors"] == 0
    readings = list(keller.iter_readings(recs))
    assert len(readings) == 30
    depths = pressure_to_depth([r.pressure_pa for r in readings])
    assert np.all((depths > 10.0) & (depths < 12.0))
    assert main(["sim", "--scene", str(tmp_path / "missing.toml"), "--out", str(out)]) == 1
    assert "auvlink: error:" in capsys.readouterr().err
