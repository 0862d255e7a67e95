"""Teledyne RDI PD6 codec: one ASCII line <-> one record (SI units).

Spec: Teledyne RD Instruments, "WorkHorse Commands and Output Data Format", "DVL Output Data
Format (PD6)". Lines (``\\r\\n`` terminated; canonical field widths in brackets)::

    :SA,±PP.PP,±RR.RR,HHH.HH                             pitch, roll, heading (deg)   [6,6,6]
    :TS,YYMMDDHHmmsshh,SS.S,+TT.T,DDDD.D,CCCC.C,BBB      time, salinity, temperature, depth,
                                                         speed of sound, BIT          [14,4,5,6,6,3]
    :WI/:BI,±XXXXX,±YYYYY,±ZZZZZ,±EEEEE,S                instrument x, y, z, error (mm/s) [6 each]
    :WS/:BS,±TTTTT,±LLLLL,±NNNNN,S                       ship transverse, longitudinal, normal
    :WE/:BE,±EEEEE,±NNNNN,±UUUUU,S                       earth east, north, up
    :WD/:BD,±EEEEEEEE.EE,±NNNNNNNN.NN,±UUUUUUUU.UU,DDDD.DD,TTT.TT
            east, north, up distance (m), range to bottom / water-mass centre (m),
            time since the last good velocity (s)                                    [12,12,12,7,6]

``S`` is A (good) or V (bad); -32768 marks a bad velocity (NaN in the record). PD6 velocities are
the *vehicle* moving (the opposite sign of PD0 bottom track). Other firmware pads fields wider
(e.g. Pathfinder); each record keeps the widths it was decoded with (``widths``, not compared),
so ``encode(decode(line)) == line`` for any spacing with the canonical decimals. Unknown line
types (``:HM`` ...) decode to :class:`Pd6Raw` and re-encode unchanged.
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

from auvlink.codecs._util import ValueEq
from auvlink.errors import DecodeError, EncodeError
from auvlink.formats import WireFormat
from auvlink.framing.ascii_lines import LineFramer

BAD = -32768
TRACKS = {"B": "bottom", "W": "water"}
FRAMES = {"I": "instrument", "S": "ship", "E": "earth"}
_VEL_WIDTHS = {"I": (6, 6, 6, 6), "S": (6, 6, 6), "E": (6, 6, 6)}


@dataclass(frozen=True, eq=False)
class Pd6Attitude(ValueEq):
    """``:SA`` system attitude."""

    pitch_rad: float
    roll_rad: float
    heading_rad: float
    widths: tuple[int, ...] | None = field(default=None, compare=False, repr=False)
    tag: ClassVar[str] = "SA"


@dataclass(frozen=True, eq=False)
class Pd6Timing(ValueEq):
    """``:TS`` timing and scaling."""

    time: dt.datetime  # UTC, hundredths of a second
    salinity_ppt: float
    temperature_c: float
    depth_m: float  # depth of the transducer face
    speed_of_sound_mps: float
    bit_result: int
    widths: tuple[int, ...] | None = field(default=None, compare=False, repr=False)
    tag: ClassVar[str] = "TS"


@dataclass(frozen=True, eq=False)
class Pd6Velocity(ValueEq):
    """``:BI :BS :BE :WI :WS :WE``: bottom- or water-track velocity of the vehicle (NaN = bad)."""

    tag: str
    velocity_mps: tuple[float, float, float]  # instrument x,y,z / ship transverse,longit.,normal / E,N,U
    error_velocity_mps: float | None  # instrument frame only
    status: str  # "A" good, "V" bad
    widths: tuple[int, ...] | None = field(default=None, compare=False, repr=False)

    @property
    def valid(self) -> bool:
        return self.status == "A"

    @property
    def track(self) -> str:
        return TRACKS[self.tag[0]]

    @property
    def frame(self) -> str:
        return FRAMES[self.tag[1]]


@dataclass(frozen=True, eq=False)
class Pd6Distance(ValueEq):
    """``:BD :WD``: earth-referenced distance made good, range, time since the last good velocity."""

    tag: str
    east_m: float
    north_m: float
    up_m: float
    range_m: float  # BD: range to bottom; WD: range to the water-mass layer centre
    time_since_good_s: float
    widths: tuple[int, ...] | None = field(default=None, compare=False, repr=False)


@dataclass(frozen=True, eq=False)
class Pd6Raw(ValueEq):
    """A line type this codec does not interpret (``:HM`` ...), kept as its text (CR LF excluded)."""

    tag: str
    text: str


Pd6Record = Pd6Attitude | Pd6Timing | Pd6Velocity | Pd6Distance | Pd6Raw


def _err(msg: str) -> DecodeError:
    return DecodeError(f"pd6: {msg}", fmt="pd6")


def _f(value: float, width: int, decimals: int, sign: bool) -> str:
    return f"{value:{'+' if sign else ''}{width}.{decimals}f}"


def _mm(value: float, width: int) -> str:
    return f"{BAD if math.isnan(value) else round(value * 1000.0):+{width}d}"


def _parse_mm(text: str) -> float:
    v = int(text)
    return math.nan if v == BAD else v / 1000.0


def decode(line: bytes) -> Pd6Record:
    """One PD6 line (CR LF optional) -> record."""
    try:
        text = bytes(line).decode("ascii")
    except UnicodeDecodeError as exc:
        raise _err("line is not ASCII") from exc
    text = text.removesuffix("\n").removesuffix("\r")
    if len(text) < 3 or text[0] != ":" or (len(text) > 3 and text[3] != ","):
        raise _err(f"not a PD6 line: {text[:20]!r}")
    tag = text[1:3]
    parts = text[4:].split(",")
    widths = tuple(len(p) for p in parts)
    try:
        if tag == "SA" and len(parts) == 3:
            p, r, h = (math.radians(float(x)) for x in parts)
            return Pd6Attitude(p, r, h, widths)
        if tag == "TS" and len(parts) == 6:
            s = parts[0].strip()
            if len(s) != 14 or not s.isdigit():
                raise _err(f"bad timestamp {s!r}")
            y, mo, d, h, mi, sec, cs = (int(s[k : k + 2]) for k in range(0, 14, 2))
            t = dt.datetime(2000 + y, mo, d, h, mi, sec, cs * 10_000, dt.UTC)
            return Pd6Timing(t, float(parts[1]), float(parts[2]), float(parts[3]), float(parts[4]),
                             int(parts[5]), widths)
        if tag[0] in TRACKS and tag[1] in FRAMES and len(parts) == len(_VEL_WIDTHS[tag[1]]) + 1:
            vals = [_parse_mm(x) for x in parts[:-1]]
            status = parts[-1]
            if len(status) != 1:
                raise _err(f"bad status {status!r}")
            err = vals[3] if tag[1] == "I" else None
            return Pd6Velocity(tag, (vals[0], vals[1], vals[2]), err, status, widths[:-1])
        if tag[0] in TRACKS and tag[1] == "D" and len(parts) == 5:
            e, n, u, rng, tsg = (float(x) for x in parts)
            return Pd6Distance(tag, e, n, u, rng, tsg, widths)
    except ValueError as exc:
        raise _err(f"bad field in {text!r}") from exc
    if tag in ("SA", "TS") or (tag[0] in TRACKS and (tag[1] in FRAMES or tag[1] == "D")):
        raise _err(f"wrong number of fields in {text!r}")
    return Pd6Raw(tag, text)


def _widths(rec: Any, canonical: tuple[int, ...]) -> tuple[int, ...]:
    w = rec.widths
    return canonical if w is None or len(w) != len(canonical) else w


def encode(rec: Pd6Record) -> bytes:
    """Record -> PD6 line with CR LF (canonical widths unless the record carries its own)."""
    if isinstance(rec, Pd6Attitude):
        w = _widths(rec, (6, 6, 6))
        body = ",".join((_f(math.degrees(rec.pitch_rad), w[0], 2, True),
                         _f(math.degrees(rec.roll_rad), w[1], 2, True),
                         _f(math.degrees(rec.heading_rad), w[2], 2, False)))
    elif isinstance(rec, Pd6Timing):
        w = _widths(rec, (14, 4, 5, 6, 6, 3))
        t = rec.time.astimezone(dt.UTC) if rec.time.tzinfo else rec.time
        if not 2000 <= t.year < 2100:
            raise EncodeError(f"pd6: year {t.year} does not fit YY")
        stamp = f"{t:%y%m%d%H%M%S}{t.microsecond // 10_000:02d}"
        body = ",".join((f"{stamp:>{w[0]}}", _f(rec.salinity_ppt, w[1], 1, False),
                         _f(rec.temperature_c, w[2], 1, True), _f(rec.depth_m, w[3], 1, False),
                         _f(rec.speed_of_sound_mps, w[4], 1, False), f"{rec.bit_result:{w[5]}d}"))
    elif isinstance(rec, Pd6Velocity):
        canonical = _VEL_WIDTHS.get(rec.tag[1:2])
        if rec.tag[:1] not in TRACKS or canonical is None:
            raise EncodeError(f"pd6: {rec.tag!r} is not a velocity line")
        w = _widths(rec, canonical)
        vals = list(rec.velocity_mps)
        if len(canonical) == 4:
            vals.append(math.nan if rec.error_velocity_mps is None else rec.error_velocity_mps)
        if any(not math.isnan(v) and abs(round(v * 1000.0)) > 32767 for v in vals):
            raise EncodeError(f"pd6: velocity beyond +-32.767 m/s in {rec!r}")
        body = ",".join([*(_mm(v, wi) for v, wi in zip(vals, w, strict=True)), rec.status])
    elif isinstance(rec, Pd6Distance):
        w = _widths(rec, (12, 12, 12, 7, 6))
        body = ",".join((_f(rec.east_m, w[0], 2, True), _f(rec.north_m, w[1], 2, True),
                         _f(rec.up_m, w[2], 2, True), _f(rec.range_m, w[3], 2, False),
                         _f(rec.time_since_good_s, w[4], 2, False)))
    elif isinstance(rec, Pd6Raw):
        return rec.text.encode("ascii") + b"\r\n"
    else:
        raise EncodeError(f"pd6: cannot encode {type(rec).__name__}")
    return f":{rec.tag},{body}\r\n".encode("ascii")


def _num(v: float | None, nd: int) -> float | None:
    return None if v is None or math.isnan(v) else round(v, nd)


def to_json(rec: Pd6Record) -> dict[str, Any]:
    """JSON-ready dict (SI; angles in degrees; null where bad)."""
    out: dict[str, Any] = {"type": rec.tag}
    if isinstance(rec, Pd6Attitude):
        out |= {"pitch_deg": _num(math.degrees(rec.pitch_rad), 2),
                "roll_deg": _num(math.degrees(rec.roll_rad), 2),
                "heading_deg": _num(math.degrees(rec.heading_rad), 2)}
    elif isinstance(rec, Pd6Timing):
        out |= {"time": rec.time.isoformat(timespec="milliseconds").replace("+00:00", "Z"),
                "salinity_ppt": rec.salinity_ppt, "temperature_c": rec.temperature_c, "depth_m": rec.depth_m,
                "speed_of_sound_mps": rec.speed_of_sound_mps, "bit_result": rec.bit_result}
    elif isinstance(rec, Pd6Velocity):
        out |= {"track": rec.track, "frame": rec.frame,
                "velocity_mps": [_num(v, 3) for v in rec.velocity_mps],
                "error_velocity_mps": _num(rec.error_velocity_mps, 3), "valid": rec.valid}
    elif isinstance(rec, Pd6Distance):
        out |= {"track": TRACKS[rec.tag[0]], "east_m": rec.east_m, "north_m": rec.north_m, "up_m": rec.up_m,
                "range_m": rec.range_m, "time_since_good_s": rec.time_since_good_s}
    else:
        out["text"] = rec.text
    return out


def sensor_time(rec: Pd6Record) -> float | None:
    """The ``:TS`` line's clock in s since the UNIX epoch; other lines carry no time."""
    return rec.time.timestamp() if isinstance(rec, Pd6Timing) else None


class Pd6Framer(LineFramer):
    """PD6 lines: ``:`` through CR LF; a ``:`` inside a line means the line before it was cut."""

    format_name = "pd6"

    def __init__(self) -> None:
        super().__init__(b"\r\n", b":", max_length=256, resync_on_start=True)


WIRE_FORMAT = WireFormat(
    name="pd6",
    encoding="rdi.pd6",
    description="Teledyne RDI PD6 ASCII navigation lines",
    decode=decode,
    encode=encode,
    framer=Pd6Framer,
    sensor_time=sensor_time,
    to_json=to_json,
)
