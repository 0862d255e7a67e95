"""Blueprint Subsea Oculus multibeam imaging sonar network messages (M370s/M750d/M1200d/M3000d).

Public protocol facts followed (Oculus SDK header ``Oculus.h`` by Blueprint Subsea, as published in
apl-ocean-engineering/liboculus ``thirdparty/Oculus/Oculus.h`` and ``include/liboculus/*.h``; read for
facts, nothing copied), all little-endian and byte-packed (tables in :mod:`auvlink.framing.oculus_defs`):

* every message starts with a 16-byte header: ``oculusId`` 0x4F53, ``srcDeviceId``, ``dstDeviceId``,
  ``msgId``, ``msgVersion`` (u16 each), ``payloadSize`` (u32, bytes after the header), ``spare`` (u16);
* ``SimpleFire`` (msg 0x15) commands the sonar on TCP port 52100: ``masterMode`` (1 = low frequency,
  2 = high frequency), ``pingRate``, ``networkSpeed``, ``gammaCorrection``, ``flags`` (bit 0 range in m,
  bit 1 16-bit data, bit 2 send a gain per range line, bit 3 simple return, bit 6 512 beams), range,
  gain (%), speed of sound (m/s, 0 = internal), salinity (ppt); V2 (``msgVersion`` 2) adds ``extFlags``
  (0x200: 32-bit data) and 8 reserved u32;
* ``SimplePingResult`` (msg 0x23) answers it: the fire message it obeyed (V1 for versions 0/1, V2 for
  version 2), then ping id, status, frequency (Hz), temperature (degC), pressure (bar), [V2: heading,
  pitch, roll (deg)], speed of sound used (m/s), ping start time (V1 u32, V2 s since power-up),
  ``dataSize`` (0/1/3 = 8/16/32-bit samples), range resolution (m per range line), ``nRanges``, ``nBeams``,
  [V2: 4 spare u32], ``imageOffset`` (from the message start), ``imageSize``, ``messageSize``; then the
  bearing table (``nBeams`` int16 in 0.01 deg) right after those fields; the image at ``imageOffset``,
  range-line-major (one row per range line, ``nBeams`` samples), each row led by a 4-byte gain
  (liboculus reads it as float32) when fire flag bit 2 is set;
* the status message (msg 0x01) the sonar broadcasts on UDP port 52102: device id, type, part number,
  status, firmware versions, IP address/mask, connected IP, MAC, 8 temperatures (degC), pressure (bar).

Records keep what the wire has, so ``encode(decode(x)) == x``: bytes between the bearing table and the
image (the capture's image sits at offset 2048) and after the image are kept raw. Bearings are rad
(+ to starboard as the table's sign); other angles, pressure and the gain stay in the protocol's units,
with SI properties. Messages of other ids decode to :class:`OculusMessage` (header + raw payload).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from auvlink.codecs.oculus_messages import (
    OculusFire,
    OculusFireCommand,
    OculusHeader,
    OculusMessage,
    OculusStatus,
    decode_fire,
    decode_fire_command,
    decode_header,
    decode_other,
    decode_status,
    encode_fire,
    encode_fire_command,
    encode_header,
    encode_other,
    encode_status,
    fire_layout,
)
from auvlink.errors import DecodeError, EncodeError
from auvlink.formats import WireFormat
from auvlink.framing import oculus_defs as d
from auvlink.framing.oculus import OculusFramer

__all__ = ["WIRE_FORMAT", "OculusFire", "OculusFireCommand", "OculusHeader", "OculusMessage", "OculusPing",
           "OculusStatus", "decode", "encode", "to_json"]


def _fail(msg: str) -> DecodeError:
    return DecodeError(f"oculus: {msg}", fmt="oculus")


@dataclass(frozen=True, eq=False)
class OculusPing:
    """A SimplePingResult (msg 0x23, V1 for versions 0/1, V2 for version 2).

    ``image`` is (n_ranges, n_beams) of uint8/uint16/uint32, row 0 the nearest range line;
    ``row_gain`` the per-range-line gain (float32, one per row) when the fire flags ask for it. Decoded, ``image``
    is a read-only view on the message's bytes (no copy of a 2 MB M750d image; the record keeps the message alive).
    """

    header: OculusHeader
    fire: OculusFire
    ping_id: int
    status: int
    frequency_hz: float
    temperature_c: float
    pressure_bar: float
    speed_of_sound_mps: float
    ping_start_time: float  # V1: the sonar's u32 counter; V2: s since power-up
    range_resolution_m: float
    bearings_rad: npt.NDArray[np.float64]
    image: npt.NDArray[Any]
    row_gain: npt.NDArray[np.float32] | None = None
    heading_deg: float = 0.0  # V2 only
    pitch_deg: float = 0.0  # V2 only
    roll_deg: float = 0.0  # V2 only
    spares: tuple[int, ...] = (0, 0, 0, 0)  # V2 only
    image_offset: int = 0  # 0: right after the bearing table
    message_size: int = 0  # the sender's ``messageSize``; 0: the message's own length
    padding: bytes = b""  # bytes between the bearing table and the image, kept as sent
    trailer: bytes = b""  # payload bytes after the image

    @property
    def n_beams(self) -> int:
        return int(self.image.shape[1])

    @property
    def n_ranges(self) -> int:
        return int(self.image.shape[0])

    @property
    def pressure_pa(self) -> float:
        return self.pressure_bar * 1e5

    @property
    def ranges_m(self) -> npt.NDArray[np.float64]:
        """Range (m) of each image row: row index x range resolution."""
        return np.arange(self.n_ranges, dtype=np.float64) * np.float64(self.range_resolution_m)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, OculusPing) and encode(self) == encode(other)

    __hash__ = None  # type: ignore[assignment]


def _ping_layout(version: int) -> Any:
    return d.PING_V2 if version == 2 else d.PING_V1


def _decode_ping(raw: bytes, header: OculusHeader) -> OculusPing:
    version = header.msg_version
    fire, pos = decode_fire(raw, d.HEADER.size, version)
    layout = _ping_layout(version)
    if len(raw) < pos + layout.size:
        raise _fail(f"ping message of {len(raw)} B is shorter than its fields ({pos + layout.size} B)")
    p = layout.unpack_from(raw, pos)
    pos += layout.size
    beams, rows = p["n_beams"], p["n_ranges"]
    sample = d.DATA_SIZE_BYTES[p["data_size"]] if p["data_size"] in (0, 1, 3) else 0
    if not sample or not 0 < beams <= d.MAX_BEAMS or not 0 < rows <= d.MAX_RANGES:
        raise _fail(f"ping with dataSize {p['data_size']}, {beams} beams, {rows} ranges is not a valid image")
    gain = 4 if fire.flags & d.FLAG_SEND_GAIN else 0
    stride = gain + beams * sample
    start, size = p["image_offset"], p["image_size"]
    if size != rows * stride or start < pos + 2 * beams or start + size > len(raw):
        raise _fail(f"image at {start} of {size} B does not fit {rows} x {beams} x {sample} B in {len(raw)} B")
    table = np.frombuffer(raw, "<i2", beams, pos)
    block = np.frombuffer(raw, np.uint8, size, start).reshape(rows, stride)
    dtype = np.dtype(f"<u{sample}")
    image = block[:, gain:].view(dtype)  # a view (read-only, like ``raw``): a ping is read, never written
    row_gain = block[:, :gain].copy().view("<f4").reshape(rows) if gain else None  # 4 B a row: copied
    extra = {"heading_deg": p["heading"], "pitch_deg": p["pitch"], "roll_deg": p["roll"],
             "spares": tuple(p[f"spare{k}"] for k in range(4))} if version == 2 else {}
    return OculusPing(
        header=header, fire=fire, ping_id=p["ping_id"], status=p["status"], frequency_hz=p["frequency"],
        temperature_c=p["temperature"], pressure_bar=p["pressure"], speed_of_sound_mps=p["speed_of_sound_used"],
        ping_start_time=p["ping_start_time"], range_resolution_m=p["range_resolution"],
        bearings_rad=np.radians(table * d.BEARING_DEG_PER_COUNT), image=image, row_gain=row_gain,
        image_offset=start, message_size=p["message_size"], padding=raw[pos + 2 * beams : start],
        trailer=raw[start + size :], **extra,
    )


def _encode_ping(ping: OculusPing) -> bytes:
    version = ping.header.msg_version
    image = np.ascontiguousarray(ping.image)
    sample = image.dtype.itemsize
    if image.ndim != 2 or image.dtype.kind != "u" or sample not in d.BYTES_DATA_SIZE:
        raise EncodeError("oculus: image must be 2-D uint8, uint16 or uint32 (range lines x beams)")
    rows, beams = image.shape
    gain = 4 if ping.fire.flags & d.FLAG_SEND_GAIN else 0
    if gain and (ping.row_gain is None or len(ping.row_gain) != rows):
        raise EncodeError("oculus: fire flags ask for a gain per range line: row_gain needs one value per row")
    if len(ping.bearings_rad) != beams:
        raise EncodeError(f"oculus: {len(ping.bearings_rad)} bearings for {beams} beams")
    table = np.round(np.degrees(ping.bearings_rad) / d.BEARING_DEG_PER_COUNT).astype("<i2")
    head_size = d.HEADER.size + fire_layout(version).size + _ping_layout(version).size
    start = head_size + 2 * beams + len(ping.padding)
    if ping.image_offset not in (0, start):
        raise EncodeError(f"oculus: image_offset {ping.image_offset} != fields + bearings + padding ({start})")
    rows_bytes = image.astype(image.dtype.newbyteorder("<"), copy=False).view(np.uint8).reshape(rows, -1)
    if gain:
        gains = np.asarray(ping.row_gain, "<f4").view(np.uint8).reshape(rows, 4)
        rows_bytes = np.hstack([gains, rows_bytes])
    size = rows * (gain + beams * sample)
    total = start + size + len(ping.trailer)
    fields = {"ping_id": ping.ping_id, "status": ping.status, "frequency": ping.frequency_hz,
              "temperature": ping.temperature_c, "pressure": ping.pressure_bar,
              "speed_of_sound_used": ping.speed_of_sound_mps, "ping_start_time": ping.ping_start_time,
              "data_size": d.BYTES_DATA_SIZE[sample], "range_resolution": ping.range_resolution_m,
              "n_ranges": rows, "n_beams": beams, "image_offset": start, "image_size": size,
              "message_size": ping.message_size or total, "heading": ping.heading_deg, "pitch": ping.pitch_deg,
              "roll": ping.roll_deg, **{f"spare{k}": v for k, v in enumerate(ping.spares)}}
    if version != 2:
        fields["ping_start_time"] = int(ping.ping_start_time)
    return b"".join([
        encode_header(ping.header, d.MSG_SIMPLE_PING_RESULT, total - d.HEADER.size),
        encode_fire(ping.fire, version), _ping_layout(version).pack(fields), table.tobytes(), ping.padding,
        rows_bytes.tobytes(), ping.trailer,
    ])


OculusRecord = OculusPing | OculusFireCommand | OculusStatus | OculusMessage


def decode(raw: bytes | bytearray | memoryview) -> OculusRecord:
    """One whole network message -> its record (:class:`DecodeError` when it is not a valid one)."""
    data = bytes(raw)
    header, msg_id = decode_header(data)
    if msg_id == d.MSG_SIMPLE_PING_RESULT:
        return _decode_ping(data, header)
    if msg_id == d.MSG_SIMPLE_FIRE:
        return decode_fire_command(data, header)
    if msg_id == d.MSG_STATUS:
        return decode_status(data, header)
    return decode_other(data, header, msg_id)


def encode(record: OculusRecord) -> bytes:
    """A record -> the network message bytes (header included)."""
    if isinstance(record, OculusPing):
        return _encode_ping(record)
    if isinstance(record, OculusFireCommand):
        return encode_fire_command(record)
    if isinstance(record, OculusStatus):
        return encode_status(record)
    if isinstance(record, OculusMessage):
        return encode_other(record)
    raise EncodeError(f"oculus: cannot encode a {type(record).__name__}")


def _fire_json(fire: OculusFire) -> dict[str, Any]:
    meters = bool(fire.flags & d.FLAG_RANGE_AS_METERS)
    return {"freq_mode": fire.master_mode, "ping_rate": fire.ping_rate, "flags": fire.flags,
            "range_demand_m" if meters else "range_demand_percent": fire.range, "gain_percent": fire.gain_percent,
            "speed_of_sound_demand_mps": fire.speed_of_sound_mps, "salinity_ppt": fire.salinity_ppt}


def to_json(record: OculusRecord) -> dict[str, Any]:
    """JSON-ready facts of a record (SI units; bearings also in deg as the sonar states them)."""
    base: dict[str, Any] = {"msg_version": record.header.msg_version, "src_device_id": record.header.src_device_id}
    if isinstance(record, OculusPing):
        deg = np.degrees(record.bearings_rad)
        return {"type": "simple_ping_result", **base, "ping_id": record.ping_id, "n_beams": record.n_beams,
                "n_ranges": record.n_ranges, "bearing_min_rad": float(record.bearings_rad.min()),
                "bearing_max_rad": float(record.bearings_rad.max()), "bearing_min_deg": round(float(deg.min()), 2),
                "bearing_max_deg": round(float(deg.max()), 2), "frequency_hz": record.frequency_hz,
                "range_resolution_m": record.range_resolution_m, "range_max_m": float(record.ranges_m[-1]),
                "speed_of_sound_mps": record.speed_of_sound_mps, "temperature_c": record.temperature_c,
                "pressure_pa": record.pressure_pa, **_fire_json(record.fire),
                "data_bits": 8 * record.image.dtype.itemsize, "image_offset": record.image_offset or None,
                "image_size": record.image.size * record.image.dtype.itemsize + 4 * record.n_ranges * (
                    record.row_gain is not None), "row_gain": record.row_gain is not None,
                "image_mean": round(float(record.image.mean()), 3)}
    if isinstance(record, OculusFireCommand):
        return {"type": "simple_fire", **base, **_fire_json(record.fire)}
    if isinstance(record, OculusStatus):
        return {"type": "status", **base, "device_id": record.device_id, "part_number": record.part_number,
                "status": record.status, "ip_addr": record.ip_addr, "mac_addr": record.mac_addr,
                "pressure_pa": record.pressure_bar * 1e5}
    return {"type": "message", **base, "msg_id": record.msg_id, "payload_size": len(record.payload)}


WIRE_FORMAT = WireFormat(
    name="oculus",
    encoding="blueprint.oculus",
    description="Blueprint Subsea Oculus network messages (SimplePingResult V1/V2, SimpleFire, status)",
    decode=decode,
    encode=encode,
    framer=OculusFramer,
    to_json=to_json,
)
