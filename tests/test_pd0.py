"""PD0 codec and framer: facts from real captures, exact round trips, built ensembles, fuzzing."""

from __future__ import annotations

import datetime as dt
import json
import math
import os
import random
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from auvlink import formats
from auvlink.codecs import pd0
from auvlink.codecs.pd0 import Pd0Ensemble, decode, encode
from auvlink.codecs.pd0_build import build
from auvlink.errors import ChecksumError, DecodeError, EncodeError
from auvlink.framing.pd0 import Pd0Framer, sum16

GOLDEN = Path(__file__).parent / "golden" / "pd0_to_json.json"
REGEN = os.environ.get("AUVLINK_REGEN_GOLDEN") == "1"
FILES = ["RDI_withBT.000", "RDI_test01.000", "winriver01.PD0", "winriver02.PD0", "RDI_7f79.000",
         "adcp_auv_51.pd0", "adcp_auv_3.pd0", "ND072023.PD0", "LB180210_3_corrupted.PD0"]


@cache
def _cut(path: Path) -> tuple[tuple[bytes, ...], Pd0Framer]:
    framer = Pd0Framer()
    frames = framer.feed(path.read_bytes()) + framer.flush()
    return tuple(frames), framer


def cut(shared_data: Path, name: str) -> tuple[tuple[bytes, ...], Pd0Framer]:
    return _cut(shared_data / "rdi" / name)


def mm(a: np.ndarray) -> list[int | None]:
    return [None if math.isnan(v) else round(v * 1000) for v in a.tolist()]


def cm(a: np.ndarray) -> list[int | None]:
    return [None if math.isnan(v) else round(v * 100) for v in a.tolist()]


# --- facts from the captures (shared/data/README.md) -----------------------------------------
def test_with_bt_facts(shared_data: Path) -> None:
    frames, framer = cut(shared_data, "RDI_withBT.000")
    assert len(frames) == 1721 and {len(f) for f in frames} == {581}
    assert framer.stats.bad_checksums == 0 and framer.stats.truncated == 1
    recs = [decode(f) for f in frames]
    all_valid = [i for i, r in enumerate(recs) if not np.isnan(r.bt_velocity_mps).any()]
    assert len(all_valid) == 898 and all_valid[0] == 507
    r = recs[507]
    assert mm(r.bt_velocity_mps) == [52, 62, 91, -3]
    assert cm(r.bt_range_m) == [686, 1039, 753, 905]
    assert r.coordinate_system == "earth" and r.fixed.firmware == "51.41"
    assert r.fixed.frequency_hz == 600e3 and r.fixed.beam_angle_deg == 20 and r.fixed.convex
    assert r.velocity_mps is not None and r.velocity_mps.shape == (17, 4)
    assert [x.ensemble_number for x in recs[:3]] == [1, 2, 3]


def test_test01_truncated_tail(shared_data: Path) -> None:
    frames, framer = cut(shared_data, "RDI_test01.000")
    assert len(frames) == 22 and framer.stats.truncated == 1
    assert framer.stats.dropped_bytes == 772 and framer.stats.bad_checksums == 0
    r = decode(frames[0])
    assert r.coordinate_system == "beam" and r.bottom_track is None
    assert (r.fixed.n_cells, r.fixed.cell_size_m) == (36, 0.5)
    assert np.all(np.isnan(r.bt_velocity_mps))


def test_winriver01_bottom_track(shared_data: Path) -> None:
    frames, _ = cut(shared_data, "winriver01.PD0")
    r = decode(frames[0])
    assert mm(r.bt_velocity_mps) == [186, -994, -50, -4]
    assert cm(r.bt_range_m) == [4171, 3926, 4130, 4090]
    assert r.coordinate_system == "ship"
    gps = [decode(f) for f in frames if b"\x22\x20" in f]
    assert any(x.raw_sections(0x2022) for x in gps)  # WinRiver NMEA data types kept raw


def test_winriver02_every_checksum_verifies(shared_data: Path) -> None:
    frames, framer = cut(shared_data, "winriver02.PD0")
    size = (shared_data / "rdi" / "winriver02.PD0").stat().st_size
    assert len(frames) == 75 and sum(map(len, frames)) == size
    assert framer.stats.bad_checksums == 0 and framer.stats.dropped_bytes == 0
    for f in frames:
        assert sum(f[:-2]) & 0xFFFF == int.from_bytes(f[-2:], "little")
        assert decode(f).raw_sections(0x2022)  # many GPS data types per ensemble, in order


def test_7f79_waves_records_skipped(shared_data: Path) -> None:
    frames, framer = cut(shared_data, "RDI_7f79.000")
    assert len(frames) == 60 and framer.waves_records == 122
    assert all(f[:2] == b"\x7f\x7f" for f in frames)
    assert [decode(f).ensemble_number for f in frames] == list(range(1, 61))


def test_adcp_auv_51(shared_data: Path) -> None:
    frames, _ = cut(shared_data, "adcp_auv_51.pd0")
    assert len(frames) == 51 and {len(f) for f in frames} == {432}
    r = decode(frames[0])
    assert mm(r.bt_velocity_mps) == [-58, -137, 12, -3]
    assert cm(r.bt_range_m) == [1423, 1426, 1369, 1481]
    assert r.fixed.firmware == "19.13"
    assert r.variable.pressure_pa is None and r.variable.y2k_century is None  # 46-byte leader
    assert r.time == dt.datetime(2014, 12, 19, 17, 17, 55, 940000, dt.UTC)


def test_nd072023_glider(shared_data: Path) -> None:
    frames, _ = cut(shared_data, "ND072023.PD0")
    assert len(frames) == 54 and {len(f) for f in frames} == {829}
    r = decode(frames[0])
    assert r.fixed.beam_angle_deg is None and r.fixed.firmware == "34.12"  # 58-byte fixed leader
    assert r.variable.y2k_month == 0 and r.variable.y2k_day is None  # 60-byte variable leader
    assert r.fixed.beam_angle == pytest.approx(math.radians(30))


def test_corrupted_file_keeps_the_good(shared_data: Path) -> None:
    frames, framer = cut(shared_data, "LB180210_3_corrupted.PD0")
    assert len(frames) == 2 and framer.stats.bad_checksums == 1
    assert framer.stats.dropped_bytes == 446
    for f in frames:
        assert encode(decode(f)) == f


@pytest.mark.parametrize("name", FILES)
def test_golden_json(shared_data: Path, name: str) -> None:
    frames, _ = cut(shared_data, name)
    picks = {"0": frames[0], "last": frames[-1]}
    if name == "RDI_withBT.000":
        picks["507"] = frames[507]
    got = {k: json.loads(json.dumps(pd0.to_json(decode(f)))) for k, f in picks.items()}
    golden = json.loads(GOLDEN.read_text()) if GOLDEN.exists() else {}
    if REGEN:  # one capture per line, so that a diff shows which file changed
        golden[name] = got
        GOLDEN.parent.mkdir(exist_ok=True)
        body = ",\n".join(f"{json.dumps(k)}: {json.dumps(v, sort_keys=True)}"
                          for k, v in sorted(golden.items()))
        GOLDEN.write_text("{\n" + body + "\n}\n")
    assert golden.get(name) == got, "run with AUVLINK_REGEN_GOLDEN=1 to regenerate after a reviewed change"


# --- codec details ---------------------------------------------------------------------------
def _sample() -> Pd0Ensemble:
    v = np.arange(12, dtype=float).reshape(3, 4) / 100.0
    v[1, 2] = np.nan
    return build(70000, 1.5e9, heading_rad=1.0, bt_velocity_mps=[0.1, np.nan, -0.2, 0.0],
                             bt_range_m=[12.0, 700.5, np.nan, 12.5], velocity_mps=v,
                             correlation=np.full((3, 4), 200), coordinate_system="earth")


def test_decode_errors() -> None:
    frame = encode(_sample())
    with pytest.raises(DecodeError):
        decode(frame[:-1])
    with pytest.raises(DecodeError):
        decode(b"\x7f\x7e" + frame[2:])
    bad = bytearray(frame)
    bad[40] ^= 0x01
    with pytest.raises(ChecksumError) as info:
        decode(bytes(bad))
    assert info.value.expected != info.value.actual
    assert decode(bytes(bad), verify=False).ensemble_number == 70000
    with pytest.raises(DecodeError):
        decode(b"\x7f\x7f" + bytes(10))


def test_build_values_and_sensor_time() -> None:
    r = _sample()
    assert r.ensemble_number == 70000 and r.coordinate_system == "earth"
    assert r.sensor_time == 1.5e9 and formats.get("pd0").sensor_time(r) == 1.5e9
    assert mm(r.bt_velocity_mps) == [100, None, -200, 0] and cm(r.bt_range_m) == [1200, 70050, None, 1250]
    assert r.velocity_mps is not None and np.isnan(r.velocity_mps[1, 2])
    j = pd0.to_json(r)
    assert j["time"] == "2017-07-14T02:40:00.000Z" and j["velocity_mps"][1][2] is None
    assert j["bt_velocity_mps"] == [0.1, None, -0.2, 0.0] and j["bt_range_m"][2] is None
    assert json.dumps(j)


def test_unknown_data_types_are_preserved() -> None:
    r = _sample()
    nmea = b"\x22\x20" + b"$GPGGA,hello*00"
    lay = pd0.Pd0Layout(order=(*r.layout.order, 0x2022, 0x7777), padding=(*r.layout.padding, b"", b""),
                        gap=b"\x00\x00")
    other = pd0.Pd0Ensemble(fixed=r.fixed, variable=r.variable, velocity_mps=r.velocity_mps,
                            correlation=r.correlation, bottom_track=r.bottom_track,
                            other=((0x2022, nmea), (0x7777, b"\x77\x77\x01")), layout=lay)
    frame = encode(other)
    back = decode(frame)
    assert back == other and back.raw_sections(0x2022) == [nmea] and encode(back) == frame


def test_encode_rejects_out_of_range() -> None:
    with pytest.raises(EncodeError):
        build(1, 0.0, bt_velocity_mps=[40.0, 0, 0, 0])
    with pytest.raises(EncodeError):
        build(1, 0.0, velocity_mps=np.zeros((2, 3)))
    with pytest.raises(EncodeError):
        build(1, 0.0, correlation=np.full((2, 4), 300))
    with pytest.raises(EncodeError):
        build(1 << 24, 0.0)


def test_wire_format_registry() -> None:
    wf = formats.get("pd0")
    assert wf.name == "pd0" and wf.encoding == "rdi.pd0" and wf.to_json is pd0.to_json
    assert isinstance(wf.framer(), Pd0Framer)


def test_sum16_matches_python() -> None:
    rng = random.Random(5)
    for n in (0, 1, 255, 256, 257, 2048, 2049, 9000):
        data = bytes(rng.getrandbits(8) for _ in range(n + 7))
        assert sum16(data, 3, n) == sum(data[3 : 3 + n]) & 0xFFFF
        assert sum16(bytearray(data), 3, n) == sum(data[3 : 3 + n]) & 0xFFFF


# --- property tests --------------------------------------------------------------------------
finite = st.floats(-30.0, 30.0, allow_nan=False)
maybe_vel = st.one_of(st.just(math.nan), finite)
maybe_range = st.one_of(st.just(math.nan), st.floats(0.01, 1000.0))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    ens=st.integers(0, (1 << 24) - 1),
    t=st.floats(946684800.0, 4102444799.0),
    att=st.tuples(st.floats(-10.0, 10.0), st.floats(-1.5, 1.5), st.floats(-1.5, 1.5)),
    temp=st.floats(-5.0, 40.0),
    btv=st.lists(maybe_vel, min_size=4, max_size=4),
    btr=st.lists(maybe_range, min_size=4, max_size=4),
    cells=st.integers(0, 20),
    coord=st.sampled_from(["beam", "instrument", "ship", "earth"]),
    seed=st.integers(0, 2**32 - 1),
)
def test_build_round_trip(ens: int, t: float, att: tuple[float, float, float], temp: float,
                          btv: list[float], btr: list[float], cells: int, coord: str, seed: int) -> None:
    rng = np.random.default_rng(seed)
    vel = rng.normal(0, 2, (cells, 4)) if cells else None
    if vel is not None:
        vel[rng.random((cells, 4)) < 0.2] = np.nan
    r = build(ens, t, heading_rad=att[0], pitch_rad=att[1], roll_rad=att[2], temperature_c=temp,
                          bt_velocity_mps=btv, bt_range_m=btr, coordinate_system=coord, velocity_mps=vel,
                          echo_intensity=None if vel is None else rng.integers(0, 256, (cells, 4)))
    frame = encode(r)
    assert decode(frame) == r and encode(decode(frame)) == frame
    assert r.ensemble_number == ens and r.coordinate_system == coord
    assert r.sensor_time == pytest.approx(t, abs=0.0051)
    assert math.remainder(r.heading_rad - att[0], 2 * math.pi) == pytest.approx(0, abs=1e-4)
    assert r.pitch_rad == pytest.approx(att[1], abs=1e-4)
    assert r.temperature_c == pytest.approx(temp, abs=0.006)
    assert np.allclose(r.bt_velocity_mps, btv, atol=5.1e-4, equal_nan=True)
    assert np.allclose(r.bt_range_m, btr, atol=5.1e-3, equal_nan=True)
    if vel is not None:
        assert r.velocity_mps is not None and np.allclose(r.velocity_mps, vel, atol=5.1e-4, equal_nan=True)


