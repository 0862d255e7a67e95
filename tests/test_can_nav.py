"""CAN navigation codec (DBC via cantools), the 16-byte raw CAN frame and its framer."""

from __future__ import annotations

import math

import can
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from auvlink import formats
from auvlink.codecs import can_nav
from auvlink.decode_file import decode_bytes
from auvlink.errors import DecodeError, EncodeError
from auvlink.framing.can_frames import (
    FRAME_SIZE,
    MARKER,
    CanFrame,
    frame_problem,
    frame_to_message,
    message_to_frame,
    pack_frame,
    unpack_frame,
)

EXPECTED = {
    "DVL_BT_VELOCITY": (0x120, {"vx", "vy", "vz", "counter", "valid"}),
    "DVL_ALTITUDE": (0x121, {"altitude", "fom", "counter", "valid"}),
    "GYRO_RATE": (0x130, {"rate_z", "counter", "valid"}),
    "GYRO_RATE_XY": (0x131, {"rate_x", "rate_y"}),
    "ATTITUDE": (0x132, {"heading", "pitch", "roll", "counter", "valid"}),
    "PRESSURE": (0x140, {"pressure", "temperature_c", "counter"}),
    "DEPTH": (0x141, {"depth", "counter", "valid"}),
}


def test_dbc_contents() -> None:
    db = can_nav.database()
    assert can_nav.database() is db  # loaded once
    assert can_nav.message_names() == list(EXPECTED)
    for msg in db.messages:
        frame_id, signals = EXPECTED[msg.name]
        assert msg.frame_id == frame_id and not msg.is_extended_frame and msg.length == 8
        assert {s.name for s in msg.signals} == signals
    units = {s.name: s.unit for m in db.messages for s in m.signals}
    assert units["vx"] == "m/s" and units["rate_z"] == "rad/s" and units["heading"] == "rad"
    assert units["pressure"] == "Pa" and units["depth"] == "m" and units["temperature_c"] == "degC"
    assert "BO_ 288 DVL_BT_VELOCITY" in can_nav.dbc_text()


def test_raw_frame_layout() -> None:
    rec = can_nav.build("DVL_BT_VELOCITY", vx=1.234, vy=-0.5, vz=0.001, counter=7)
    raw = can_nav.encode(rec)
    assert len(raw) == FRAME_SIZE
    assert raw[:8] == bytes([0, 0, 0x01, 0x20, 0x00, 8]) + MARKER
    assert raw[8:] == (1234).to_bytes(2, "little") + (-500).to_bytes(2, "little", signed=True) + bytes(
        [1, 0, 7, 1]
    )
    assert rec.signals == {"vx": 1.234, "vy": -0.5, "vz": 0.001, "counter": 7.0, "valid": 1.0}


@pytest.mark.parametrize(
    ("name", "values", "tolerance"),
    [
        ("DVL_BT_VELOCITY", {"vx": 1.0123, "vy": -0.2467, "vz": 0.0311, "counter": 200, "valid": 0}, 5e-4),
        ("DVL_ALTITUDE", {"altitude": 4.8321, "fom": 0.0123}, 5e-4),
        ("GYRO_RATE", {"rate_z": 7.2921159e-5, "counter": 3}, 5e-9),
        ("GYRO_RATE_XY", {"rate_x": -0.0123456789, "rate_y": 1.5}, 5e-9),
        ("ATTITUDE", {"heading": math.radians(359.99), "pitch": -0.05, "roll": math.radians(-179.9)}, 5e-5),
        ("PRESSURE", {"pressure": 301325.4, "temperature_c": 12.345, "counter": 255}, 0.5),
        ("DEPTH", {"depth": 20.0004, "counter": 1}, 5e-4),
    ],
)
def test_values_within_scale(name: str, values: dict[str, float], tolerance: float) -> None:
    rec = can_nav.build(name, **values)
    assert rec.name == name and rec.arbitration_id == EXPECTED[name][0]
    raw = can_nav.encode(rec)
    dec = can_nav.decode(raw)
    assert dec == rec and can_nav.encode(dec) == raw
    for key, want in values.items():
        assert dec.signals[key] == pytest.approx(want, abs=tolerance), key
    if "valid" in dec.signals and "valid" not in values:
        assert dec.signals["valid"] == 1.0  # the DBC start value
    if "counter" in dec.signals and "counter" not in values:
        assert dec.signals["counter"] == 0.0


def test_errors() -> None:
    unknown = pack_frame(CanFrame(0x7FF, bytes(8)))
    with pytest.raises(DecodeError, match="0x7FF"):
        can_nav.decode(unknown)
    with pytest.raises(DecodeError, match="0x120 \\(extended\\)"):
        can_nav.decode(pack_frame(CanFrame(0x120, bytes(8), is_extended_id=True)))
    with pytest.raises(DecodeError, match="remote"):
        can_nav.decode(pack_frame(CanFrame(0x120, is_remote_frame=True, remote_dlc=8)))
    with pytest.raises(DecodeError, match="data bytes"):
        can_nav.decode(pack_frame(CanFrame(0x120, bytes(4))))
    with pytest.raises(DecodeError):
        can_nav.decode(b"\x00" * 15)
    with pytest.raises(EncodeError, match="no message"):
        can_nav.build("NOPE")
    with pytest.raises(EncodeError, match="no signal"):
        can_nav.build("DEPTH", dpth=1.0)
    with pytest.raises(EncodeError):
        can_nav.build("ATTITUDE", pitch=2.0)  # beyond +-pi/2
    with pytest.raises(EncodeError):
        can_nav.build("DVL_BT_VELOCITY", vx=40.0)
    rec = can_nav.build("DEPTH", depth=1.0)
    with pytest.raises(EncodeError):
        can_nav.encode(can_nav.CanNavRecord(0x999, "DEPTH", rec.signals))


def _raw_values(draw: st.DrawFn, name: str) -> dict[str, int]:
    msg = can_nav.database().get_message_by_name(name)
    out = {}
    for s in msg.signals:
        lo = math.ceil((s.minimum - s.offset) / s.scale - 1e-6)
        hi = math.floor((s.maximum - s.offset) / s.scale + 1e-6)
        out[s.name] = draw(st.integers(lo, hi))
    return out


@settings(max_examples=200, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_round_trips_any_value(data: st.DataObject) -> None:
    name = data.draw(st.sampled_from(list(EXPECTED)))
    msg = can_nav.database().get_message_by_name(name)
    raw_vals = _raw_values(data.draw, name)
    payload = msg.encode(raw_vals, scaling=False)
    raw = pack_frame(CanFrame(msg.frame_id, payload))
    rec = can_nav.decode(raw)
    assert can_nav.encode(rec) == raw  # encode(decode(x)) == x
    assert can_nav.decode(can_nav.encode(rec)) == rec  # decode(encode(r)) == r
    for s in msg.signals:
        assert rec.signals[s.name] == pytest.approx(raw_vals[s.name] * s.scale + s.offset)


# --- raw frames and python-can -----------------------------------------------------------
MESSAGES = [
    can.Message(arbitration_id=0x120, data=bytes(range(8)), is_extended_id=False),
    can.Message(arbitration_id=0x1ABCDEF0 & 0x1FFFFFFF, data=b"\x01\x02", is_extended_id=True),
    can.Message(arbitration_id=0x7FF, data=b"", is_extended_id=False),
    can.Message(arbitration_id=0x123, is_remote_frame=True, dlc=6, is_extended_id=False),
    can.Message(arbitration_id=0x0, is_error_frame=True, data=b"\x04\x00\x00", is_extended_id=False),
    can.Message(arbitration_id=0x321, data=b"\xaa" * 8, is_fd=True, bitrate_switch=True,
                error_state_indicator=True, is_extended_id=False),
]


@pytest.mark.parametrize("msg", MESSAGES, ids=lambda m: f"{m.arbitration_id:X}")
def test_python_can_round_trip(msg: can.Message) -> None:
    raw = message_to_frame(msg)
    assert len(raw) == FRAME_SIZE and frame_problem(raw) is None
    back = frame_to_message(raw, timestamp=msg.timestamp)
    assert back.equals(msg, timestamp_delta=None), (back, msg)
    assert message_to_frame(back) == raw


def test_fd_payload_too_long_and_invalid_frames() -> None:
    with pytest.raises(EncodeError, match="9 data bytes"):
        message_to_frame(can.Message(arbitration_id=1, data=bytes(9), is_fd=True))
    good = bytearray(message_to_frame(MESSAGES[0]))
    for index, value, why in ((6, 0, "marker"), (4, 0x40, "flag"), (5, 9, "DLC"), (4, 0x10, "non-FD"),
                              (0, 0x20, "exceeds"), (2, 0x08, "exceeds")):
        bad = bytearray(good)
        bad[index] = value
        assert why in (frame_problem(bad) or ""), (index, value)
        with pytest.raises(DecodeError):
            unpack_frame(bytes(bad))
    short = bytearray(message_to_frame(MESSAGES[1]))
    short[12] = 1  # a data byte after DLC = 2
    assert "padding" in (frame_problem(short) or "")


def test_over_a_virtual_bus() -> None:
    with can.Bus(interface="virtual", channel="auvlink-test-nav") as tx, \
         can.Bus(interface="virtual", channel="auvlink-test-nav") as rx:
        raw_out = can_nav.encode(can_nav.build("GYRO_RATE", rate_z=0.01, counter=9))
        tx.send(frame_to_message(raw_out))
        msg = rx.recv(timeout=1.0)
    assert msg is not None
    rec = can_nav.decode(message_to_frame(msg))
    assert rec.name == "GYRO_RATE" and rec.signals["rate_z"] == pytest.approx(0.01)


# --- framer ------------------------------------------------------------------------------
def test_registry_and_file_decode() -> None:
    fmt = formats.get("can")
    assert fmt.encoding == "can.dbc" and fmt.framer().format_name == "can"
    recs = [can_nav.build("DEPTH", depth=float(i), counter=i) for i in range(20)]
    unknown = pack_frame(CanFrame(0x555, bytes(8)))
    stream = b"\x13\x37" + b"".join(can_nav.encode(r) for r in recs[:10]) + unknown + b"".join(
        can_nav.encode(r) for r in recs[10:]
    )
    got: list[can_nav.CanNavRecord] = []
    res = decode_bytes(stream, fmt, got.append)
    assert got == recs and res.decode_errors == 1 and "0x555" in res.problems[0]
    assert res.framer["dropped_bytes"] == 2
    assert fmt.to_json is not None and fmt.to_json(got[3])["signals"]["depth"] == 3.0
