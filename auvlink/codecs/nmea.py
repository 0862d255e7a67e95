"""NMEA 0183 GNSS receiver sentences (``GGA``, ``RMC``, ``ZDA``), parsed and checksum-checked by pynmea2.

Every sentence a GNSS receiver sends is ``$`` + talker (``GP``, ``GN``, ``GL``, ...) + type + ``,``
fields + ``*hh`` CR LF. pynmea2 does the parsing and the checksum (a sentence without a checksum is
rejected); this module turns its fields into SI records:

- ``GGA`` (fix data): :class:`GgaFix` - UTC time of day, WGS84 latitude / longitude in degrees (the
  boundary unit of geodesy, kept as such), fix quality (0 = no fix, 1 = GPS, 2 = DGPS, 4 = RTK
  fixed, 5 = RTK float, 6 = estimated, ...), satellites used, HDOP, antenna altitude above mean sea
  level and geoid separation in m, age of the differential corrections in s;
- ``RMC`` (recommended minimum): :class:`RmcFix` - UTC date and time, status (``A`` valid / ``V``
  void), latitude / longitude, speed over ground in m/s, course over ground in rad (true), mode;
- ``ZDA`` (time and date): :class:`ZdaTime` - UTC date and time, local zone;
- any other sentence that passes the checksum: :class:`NmeaSentence` (talker, type, fields as sent).

A field left empty (a receiver without a fix sends ``$GPGGA,,,,,,0,00,99.99,,,,,,*48``) decodes to
NaN (numbers) or -1 (satellites). A position out of range (latitude outside [-90, 90], longitude outside
[-180, 180]) or a HDOP <= 0 decodes as sent, with ``has_fix`` false and ``implausible`` saying why
(:mod:`auvlink.codecs.nmea_checks`, which also says which fix qualities are measurements). Every
record keeps its fields exactly as sent (``data``), so
``encode(decode(line)) == line`` for a line with CR LF; :func:`build_gga`, :func:`build_rmc` and
:func:`build_zda` make the records the simulator sends (pynmea2 renders the sentence and its checksum).
"""

from __future__ import annotations

import calendar
import datetime as dt
import math
from dataclasses import dataclass
from typing import Any

from auvlink.codecs._util import ValueEq
from auvlink.codecs.nmea_checks import QUALITY, RMC_MODE_QUALITY, implausible
from auvlink.errors import ChecksumError, DecodeError, EncodeError
from auvlink.formats import WireFormat
from auvlink.framing.nmea import NmeaFramer

FMT = "nmea"
KNOT = 1852.0 / 3600.0  # m/s


def _num(text: str) -> float:
    return float(text) if text.strip() else math.nan


def _seconds_of_day(text: str) -> float:
    """``hhmmss.ss`` -> seconds since UTC midnight (NaN when empty)."""
    if not text.strip():
        return math.nan
    if len(text) < 6 or not text[:6].isdigit():
        raise ValueError(f"not an hhmmss time: {text!r}")
    return int(text[:2]) * 3600.0 + int(text[2:4]) * 60.0 + float(text[4:])


def _angle(m: Any, value: str, hemisphere: str, attr: str) -> float:
    """Latitude / longitude in degrees from pynmea2's converter; NaN when the field is empty."""
    if not value.strip():
        return math.nan
    if hemisphere not in ("N", "S", "E", "W"):
        raise ValueError(f"hemisphere must be N, S, E or W, got {hemisphere!r}")
    return float(getattr(m, attr))


def _epoch(date: dt.date | None, time_s: float) -> float | None:
    if date is None or not math.isfinite(time_s):
        return None
    return calendar.timegm(date.timetuple()) + time_s


@dataclass(frozen=True, eq=False)
class GgaFix(ValueEq):
    """A GGA sentence in SI units (positions WGS84 degrees, heights m)."""

    talker: str
    time_s: float  # s since UTC midnight (NaN when empty)
    latitude_deg: float  # WGS84, + north (NaN without a fix)
    longitude_deg: float  # WGS84, + east
    quality: int  # fix quality code (QUALITY)
    satellites: int  # satellites used (-1 when empty)
    hdop: float  # horizontal dilution of precision
    altitude_m: float  # antenna above mean sea level (geoid)
    geoid_separation_m: float  # geoid above the WGS84 ellipsoid
    dgps_age_s: float  # age of the differential corrections
    data: tuple[str, ...] = ()  # the fields as sent

    @property
    def implausible(self) -> str | None:
        """Why the position sent is not a possible fix (:func:`auvlink.codecs.nmea_checks.implausible`), or None."""
        if math.isnan(self.latitude_deg) and math.isnan(self.longitude_deg):
            return None  # no position sent
        return implausible(self.latitude_deg, self.longitude_deg, self.hdop)

    @property
    def has_fix(self) -> bool:
        """Quality > 0 and a finite, plausible position (quality 6, 7, 8 included: see :attr:`quality`)."""
        return self.quality > 0 and math.isfinite(self.latitude_deg) and math.isfinite(self.longitude_deg) and \
            self.implausible is None

    @property
    def ellipsoidal_height_m(self) -> float:
        """Antenna height above the WGS84 ellipsoid (altitude + geoid separation; NaN when unknown)."""
        return self.altitude_m + (0.0 if math.isnan(self.geoid_separation_m) else self.geoid_separation_m)


@dataclass(frozen=True, eq=False)
class RmcFix(ValueEq):
    """An RMC sentence in SI units."""

    talker: str
    time_s: float
    date: dt.date | None
    valid: bool  # status A (valid) or V (void)
    latitude_deg: float
    longitude_deg: float
    speed_mps: float  # over ground
    course_rad: float  # over ground, true, 0 = north, clockwise
    mode: str  # A autonomous, D differential, R RTK, F float, E estimated, N not valid ("" before NMEA 2.3)
    data: tuple[str, ...] = ()

    @property
    def implausible(self) -> str | None:
        """Why the position sent is not a possible fix, or None (also None when no position was sent)."""
        if math.isnan(self.latitude_deg) and math.isnan(self.longitude_deg):
            return None
        return implausible(self.latitude_deg, self.longitude_deg)

    @property
    def quality(self) -> int:
        """The GGA fix quality of the same meaning (0 for status V; RMC_MODE_QUALITY; unknown modes 0)."""
        return RMC_MODE_QUALITY.get(self.mode, 0) if self.valid else 0

    @property
    def has_fix(self) -> bool:
        return self.valid and self.mode != "N" and math.isfinite(self.latitude_deg) and \
            math.isfinite(self.longitude_deg) and self.implausible is None

    @property
    def utc(self) -> float | None:
        """s since the UNIX epoch, or None without a date."""
        return _epoch(self.date, self.time_s)


@dataclass(frozen=True, eq=False)
class ZdaTime(ValueEq):
    """A ZDA sentence: UTC time and date, local zone offset."""

    talker: str
    time_s: float
    date: dt.date | None
    zone_hours: int
    zone_minutes: int
    data: tuple[str, ...] = ()

    @property
    def utc(self) -> float | None:
        return _epoch(self.date, self.time_s)


@dataclass(frozen=True, eq=False)
class NmeaSentence(ValueEq):
    """Any other checksum-valid sentence, fields as sent (``HDT``, ``GSA``, ``GSV``, ``VTG``, ...)."""

    talker: str
    sentence_type: str
    data: tuple[str, ...] = ()


NmeaRecord = GgaFix | RmcFix | ZdaTime | NmeaSentence


def _from_pynmea2(m: Any) -> NmeaRecord:
    talker = str(getattr(m, "talker", "") or "")
    data = tuple(str(x) for x in m.data)
    kind = str(m.sentence_type)
    if kind == "GGA":
        f = list(data) + [""] * (14 - len(data))
        return GgaFix(talker, _seconds_of_day(f[0]), _angle(m, f[1], f[2], "latitude"),
                      _angle(m, f[3], f[4], "longitude"), int(f[5] or 0), int(f[6]) if f[6].strip() else -1,
                      _num(f[7]), _num(f[8]), _num(f[10]), _num(f[12]), data)
    if kind == "RMC":
        f = list(data) + [""] * (12 - len(data))
        date = dt.datetime.strptime(f[8], "%d%m%y").date() if f[8].strip() else None
        return RmcFix(talker, _seconds_of_day(f[0]), date, f[1] == "A", _angle(m, f[2], f[3], "latitude"),
                      _angle(m, f[4], f[5], "longitude"), _num(f[6]) * KNOT, math.radians(_num(f[7])), f[11], data)
    if kind == "ZDA":
        y, mo, d = (str(m.data[i]).strip() for i in (3, 2, 1))
        date = dt.date(int(y), int(mo), int(d)) if y and mo and d else None
        zh, zm = str(m.data[4]).strip(), str(m.data[5]).strip()
        return ZdaTime(talker, _seconds_of_day(m.data[0]), date, int(zh) if zh else 0, int(zm) if zm else 0, data)
    return NmeaSentence(talker, kind, data)


def decode(raw: bytes) -> NmeaRecord:
    """Decode one sentence (CR LF optional); the checksum is required and checked (pynmea2)."""
    import pynmea2

    try:
        text = bytes(raw).decode("ascii").rstrip("\r\n")
    except UnicodeDecodeError as exc:
        raise DecodeError(f"{FMT}: sentence is not ASCII: {bytes(raw)[:40]!r}", fmt=FMT) from exc
    try:
        m = pynmea2.parse(text, check=True)
    except pynmea2.ChecksumError as exc:
        star = text.rfind("*")
        if star < 0:
            raise DecodeError(f"{FMT}: sentence has no '*hh' checksum: {text[:40]!r}", fmt=FMT) from exc
        try:
            expected = int(text[star + 1 : star + 3], 16)
        except ValueError as err:
            raise DecodeError(f"{FMT}: bad checksum field: {text[star:]!r}", fmt=FMT) from err
        actual = int(pynmea2.NMEASentence.checksum(text.lstrip("$!")[: text.lstrip("$!").rfind("*")]))
        raise ChecksumError(FMT, expected, actual) from exc
    except (pynmea2.ParseError, ValueError, TypeError) as exc:
        raise DecodeError(f"{FMT}: not an NMEA sentence: {text[:60]!r} ({exc})", fmt=FMT) from exc
    try:
        return _from_pynmea2(m)
    except (ValueError, TypeError, IndexError, AttributeError) as exc:
        raise DecodeError(f"{FMT}: bad {getattr(m, 'sentence_type', '?')} field in {text[:60]!r}: {exc}",
                          fmt=FMT) from exc


def encode(record: NmeaRecord) -> bytes:
    """The sentence as a receiver sends it, ``*hh`` checksum (pynmea2) and CR LF included."""
    import pynmea2

    kind = record.sentence_type if isinstance(record, NmeaSentence) else \
        {GgaFix: "GGA", RmcFix: "RMC", ZdaTime: "ZDA"}[type(record)]
    if len(record.talker) != 2 or not record.talker.isalnum():
        raise EncodeError(f"{FMT}: a talker is 2 letters (GP, GN, ...), got {record.talker!r}")
    if any(("," in f or "*" in f or "$" in f or "\n" in f) for f in record.data):
        raise EncodeError(f"{FMT}: a field may not hold ',', '*', '$' or a line break: {record.data!r}")
    cls = pynmea2.TalkerSentence.sentence_types.get(kind, pynmea2.TalkerSentence)
    try:
        text = cls(record.talker, kind, list(record.data)).render(checksum=True, dollar=True)
    except (TypeError, ValueError) as exc:
        raise EncodeError(f"{FMT}: cannot render {kind}: {exc}") from exc
    return (text + "\r\n").encode("ascii")


# --- builders (the simulator) -----------------------------------------------------------------------
def _dm(value: float, degree_digits: int, decimals: int) -> str:
    """Degrees -> ``d..dmm.mmmm`` (the NMEA angle field, absolute value)."""
    scale = 10**decimals
    total = round(abs(value) * 60.0 * scale)  # integer units of 10^-decimals minutes
    deg, rem = divmod(total, 60 * scale)
    return f"{deg:0{degree_digits}d}{rem // scale:02d}.{rem % scale:0{decimals}d}"


def _hhmmss(time_s: float) -> str:
    cs = round(time_s * 100.0) % (86400 * 100)
    h, rem = divmod(cs, 360000)
    mi, rem = divmod(rem, 6000)
    return f"{h:02d}{mi:02d}{rem // 100:02d}.{rem % 100:02d}"


def _lat_lon_fields(lat: float | None, lon: float | None, decimals: int) -> list[str]:
    if lat is None or lon is None or not (math.isfinite(lat) and math.isfinite(lon)):
        return ["", "", "", ""]
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise EncodeError(f"{FMT}: latitude {lat} / longitude {lon} out of range")
    return [_dm(lat, 2, decimals), "N" if lat >= 0 else "S", _dm(lon, 3, decimals), "E" if lon >= 0 else "W"]


def build_gga(time_s: float, latitude_deg: float | None, longitude_deg: float | None, *, quality: int = 2,
              satellites: int = 12, hdop: float = 0.8, altitude_m: float = 0.0, geoid_separation_m: float = 0.0,
              talker: str = "GN", decimals: int = 7) -> GgaFix:
    """A GGA record; ``quality=0`` (or no position) gives the empty no-fix sentence of a real receiver.

    ``decimals`` of the minutes: 7 is 0.2 mm of latitude.
    """
    if quality == 0 or latitude_deg is None or longitude_deg is None:
        data = [_hhmmss(time_s), "", "", "", "", "0", "00", "99.99", "", "", "", "", "", ""]
    else:
        data = [_hhmmss(time_s), *_lat_lon_fields(latitude_deg, longitude_deg, decimals), str(int(quality)),
                f"{int(satellites):02d}", f"{hdop:.1f}", f"{altitude_m:.3f}", "M", f"{geoid_separation_m:.3f}", "M",
                "1.0" if quality == 2 else "", "0001" if quality == 2 else ""]
    return decode(encode(GgaFix(talker, 0.0, 0.0, 0.0, 0, 0, 0.0, 0.0, 0.0, 0.0, tuple(data))))  # type: ignore[return-value]


def build_rmc(utc: float, latitude_deg: float | None, longitude_deg: float | None, *, speed_mps: float = 0.0,
              course_rad: float = 0.0, talker: str = "GN", decimals: int = 7, mode: str = "D") -> RmcFix:
    """An RMC record at ``utc`` (s since the epoch); no position gives status V, mode N."""
    t = dt.datetime.fromtimestamp(utc, dt.UTC)
    fix = latitude_deg is not None and longitude_deg is not None
    data = [_hhmmss(utc % 86400.0), "A" if fix else "V", *_lat_lon_fields(latitude_deg, longitude_deg, decimals),
            f"{speed_mps / KNOT:.2f}" if fix else "", f"{math.degrees(course_rad) % 360.0:.2f}" if fix else "",
            t.strftime("%d%m%y"), "", "", mode if fix else "N"]
    return decode(encode(RmcFix(talker, 0.0, None, False, 0.0, 0.0, 0.0, 0.0, "", tuple(data))))  # type: ignore[return-value]


def build_zda(utc: float, talker: str = "GN") -> ZdaTime:
    """A ZDA record at ``utc`` (s since the epoch), zone 00:00."""
    t = dt.datetime.fromtimestamp(utc, dt.UTC)
    data = [_hhmmss(utc % 86400.0), f"{t.day:02d}", f"{t.month:02d}", f"{t.year:04d}", "00", "00"]
    return decode(encode(ZdaTime(talker, 0.0, None, 0, 0, tuple(data))))  # type: ignore[return-value]


def sensor_time(record: Any) -> float | None:
    """UTC of RMC and ZDA sentences (they carry the date); GGA has the time of day only."""
    return record.utc if isinstance(record, RmcFix | ZdaTime) else None


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None


def to_json(record: NmeaRecord) -> dict[str, Any]:
    """JSON-ready dict in SI units (angles of position in WGS84 degrees)."""
    if isinstance(record, GgaFix):
        return {"type": "GGA", "talker": record.talker, "time_s": _finite(record.time_s),
                "latitude_deg": _finite(record.latitude_deg), "longitude_deg": _finite(record.longitude_deg),
                "quality": record.quality, "quality_name": QUALITY.get(record.quality, "unknown"),
                "satellites": record.satellites, "hdop": _finite(record.hdop), "altitude_m": _finite(record.altitude_m),
                "geoid_separation_m": _finite(record.geoid_separation_m), "dgps_age_s": _finite(record.dgps_age_s),
                "has_fix": record.has_fix, "implausible": record.implausible}
    if isinstance(record, RmcFix):
        return {"type": "RMC", "talker": record.talker, "utc": record.utc, "valid": record.valid,
                "latitude_deg": _finite(record.latitude_deg), "longitude_deg": _finite(record.longitude_deg),
                "speed_mps": _finite(record.speed_mps), "course_rad": _finite(record.course_rad), "mode": record.mode,
                "has_fix": record.has_fix, "implausible": record.implausible}
    if isinstance(record, ZdaTime):
        return {"type": "ZDA", "talker": record.talker, "utc": record.utc, "zone_hours": record.zone_hours,
                "zone_minutes": record.zone_minutes}
    return {"type": record.sentence_type, "talker": record.talker, "fields": list(record.data)}


WIRE_FORMAT = WireFormat(
    name=FMT,
    encoding="nmea.0183",
    description="NMEA 0183 GNSS sentences (GGA, RMC, ZDA; others kept as fields), via pynmea2",
    decode=decode,
    encode=encode,
    framer=NmeaFramer,
    sensor_time=sensor_time,
    to_json=to_json,
)
