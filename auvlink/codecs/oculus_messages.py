"""Oculus message header, SimpleFire (V1/V2), status broadcast and other messages: decode/encode pairs.

Layouts and their source: :mod:`auvlink.framing.oculus_defs` (Oculus.h as published in liboculus).
The ping result, which carries a fire message, is in :mod:`auvlink.codecs.oculus`.
"""

from __future__ import annotations

import socket
from dataclasses import asdict, dataclass
from typing import Any

from auvlink.errors import DecodeError, EncodeError
from auvlink.fields import Layout
from auvlink.framing import oculus_defs as d


@dataclass(frozen=True)
class OculusHeader:
    """The 16-byte message header less what the message itself fixes (id, message id, payload size)."""

    src_device_id: int = 0
    dst_device_id: int = 0
    msg_version: int = 0
    spare: int = 0


@dataclass(frozen=True)
class OculusFire:
    """The fire fields (``OculusSimpleFireMessage``; V2 adds ``ext_flags`` and ``reserved``).

    ``range`` is m when ``flags`` bit 0 is set, else % of the sonar's maximum; ``gain_percent`` %;
    ``speed_of_sound_mps`` 0 = the sonar computes it from ``salinity_ppt``; ``master_mode`` 1 = low,
    2 = high frequency; ``ping_rate`` the ``PingRateType`` code (0 10 Hz, 1 15 Hz, 2 40 Hz, 3 5 Hz,
    4 2 Hz, 5 standby).
    """

    master_mode: int = d.FREQ_MODE_HIGH
    ping_rate: int = 0
    network_speed: int = 0xFF
    gamma_correction: int = 0xFF
    flags: int = d.FLAG_RANGE_AS_METERS | d.FLAG_SIMPLE_RETURN
    range: float = 2.0
    gain_percent: float = 50.0
    speed_of_sound_mps: float = 0.0
    salinity_ppt: float = 0.0
    ext_flags: int = 0  # V2 only
    reserved: tuple[int, ...] = (0,) * 8  # V2 only


@dataclass(frozen=True)
class OculusFireCommand:
    """A SimpleFire message (msg 0x15) as sent to the sonar's data port."""

    header: OculusHeader
    fire: OculusFire


@dataclass(frozen=True)
class OculusStatus:
    """The status broadcast (msg 0x01). IP addresses dotted, MAC ``aa:bb:..``, temperatures degC."""

    header: OculusHeader
    device_id: int
    device_type: int
    part_number: int
    status: int
    firmware: tuple[int, ...]  # arm0 version, date, arm1 version, date, bitfile version, date
    ip_addr: str
    ip_mask: str
    connected_ip_addr: str
    mac_addr: str
    temperatures_c: tuple[float, ...]
    pressure_bar: float
    extra: bytes = b""  # payload bytes past the fields of Oculus.h


@dataclass(frozen=True)
class OculusMessage:
    """Any other message: its header, message id and raw payload."""

    header: OculusHeader
    msg_id: int
    payload: bytes


def _fail(msg: str) -> DecodeError:
    return DecodeError(f"oculus: {msg}", fmt="oculus")


def decode_header(raw: bytes) -> tuple[OculusHeader, int]:
    """(header, msg_id) of a whole message; checks the id and that the payload size is the rest of ``raw``."""
    if len(raw) < d.HEADER.size:
        raise _fail(f"message of {len(raw)} B is shorter than the 16-byte header")
    h = d.HEADER.unpack_from(raw)
    if h["oculus_id"] != d.OCULUS_ID:
        raise _fail(f"oculusId 0x{h['oculus_id']:04X} is not 0x4F53")
    if h["payload_size"] != len(raw) - d.HEADER.size:
        raise _fail(f"payloadSize {h['payload_size']} B but {len(raw) - d.HEADER.size} B follow the header")
    header = OculusHeader(h["src_device_id"], h["dst_device_id"], h["msg_version"], h["spare"])
    return header, h["msg_id"]


def encode_header(header: OculusHeader, msg_id: int, payload_size: int) -> bytes:
    return d.HEADER.pack({**asdict(header), "oculus_id": d.OCULUS_ID, "msg_id": msg_id,
                          "payload_size": payload_size})


def fire_layout(version: int) -> Layout:
    """The fire fields of message version ``version`` (2: ``OculusSimpleFireMessage2``)."""
    return d.FIRE_V2 if version == 2 else d.FIRE_V1


def decode_fire(raw: bytes, pos: int, version: int) -> tuple[OculusFire, int]:
    """The fire fields at ``pos`` and the position after them."""
    layout = fire_layout(version)
    if len(raw) < pos + layout.size:
        raise _fail(f"message of {len(raw)} B is shorter than its fire fields ({pos + layout.size} B)")
    f = layout.unpack_from(raw, pos)
    v2: dict[str, Any] = {"ext_flags": f["ext_flags"], "reserved": tuple(f[f"reserved{k}"] for k in range(8))} \
        if version == 2 else {}
    fire = OculusFire(f["master_mode"], f["ping_rate"], f["network_speed"], f["gamma_correction"], f["flags"],
                      f["range"], f["gain_percent"], f["speed_of_sound"], f["salinity"], **v2)
    return fire, pos + layout.size


def encode_fire(fire: OculusFire, version: int) -> bytes:
    if len(fire.reserved) != 8:
        raise EncodeError("oculus: OculusFire.reserved needs 8 values")
    values = {**asdict(fire), "speed_of_sound": fire.speed_of_sound_mps, "salinity": fire.salinity_ppt,
              **{f"reserved{k}": v for k, v in enumerate(fire.reserved)}}
    try:
        return fire_layout(version).pack(values)
    except Exception as exc:  # struct.error: a value out of its field's range
        raise EncodeError(f"oculus: fire field out of range: {exc}") from exc


def decode_fire_command(raw: bytes, header: OculusHeader) -> OculusFireCommand:
    fire, pos = decode_fire(raw, d.HEADER.size, header.msg_version)
    if pos != len(raw):
        raise _fail(f"SimpleFire of {len(raw)} B, expected {pos} B for version {header.msg_version}")
    return OculusFireCommand(header, fire)


def encode_fire_command(cmd: OculusFireCommand) -> bytes:
    body = encode_fire(cmd.fire, cmd.header.msg_version)
    return encode_header(cmd.header, d.MSG_SIMPLE_FIRE, len(body)) + body


def _mac(raw: bytes) -> str:
    return ":".join(f"{b:02x}" for b in raw)


def decode_status(raw: bytes, header: OculusHeader) -> OculusStatus:
    if len(raw) < d.HEADER.size + d.STATUS.size:
        raise _fail(f"status message of {len(raw)} B is shorter than {d.HEADER.size + d.STATUS.size} B")
    s = d.STATUS.unpack_from(raw, d.HEADER.size)
    return OculusStatus(
        header=header, device_id=s["device_id"], device_type=s["device_type"], part_number=s["part_number"],
        status=s["status"], firmware=tuple(s[f"firmware{k}"] for k in range(6)),
        ip_addr=socket.inet_ntoa(s["ip_addr"]), ip_mask=socket.inet_ntoa(s["ip_mask"]),
        connected_ip_addr=socket.inet_ntoa(s["connected_ip_addr"]), mac_addr=_mac(s["mac_addr"]),
        temperatures_c=tuple(s[f"temperature{k}"] for k in range(8)), pressure_bar=s["pressure"],
        extra=raw[d.HEADER.size + d.STATUS.size :],
    )


def encode_status(st: OculusStatus) -> bytes:
    try:
        values = {
            "device_id": st.device_id, "device_type": st.device_type, "part_number": st.part_number,
            "status": st.status, **{f"firmware{k}": v for k, v in enumerate(st.firmware)},
            "ip_addr": socket.inet_aton(st.ip_addr), "ip_mask": socket.inet_aton(st.ip_mask),
            "connected_ip_addr": socket.inet_aton(st.connected_ip_addr),
            "mac_addr": bytes.fromhex(st.mac_addr.replace(":", "")),
            **{f"temperature{k}": v for k, v in enumerate(st.temperatures_c)}, "pressure": st.pressure_bar,
        }
        body = d.STATUS.pack(values) + st.extra
    except (OSError, ValueError, KeyError, Exception) as exc:
        raise EncodeError(f"oculus: status field out of range: {exc}") from exc
    return encode_header(st.header, d.MSG_STATUS, len(body)) + body


def decode_other(raw: bytes, header: OculusHeader, msg_id: int) -> OculusMessage:
    return OculusMessage(header, msg_id, raw[d.HEADER.size :])


def encode_other(msg: OculusMessage) -> bytes:
    return encode_header(msg.header, msg.msg_id, len(msg.payload)) + msg.payload
