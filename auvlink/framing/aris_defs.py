"""Field tables of the ARIS recording: the 1024-byte file header and the 1024-byte frame header.

Transcribed (names, types, offsets) from SoundMetrics aris-file-sdk (MIT licence),
``type-definitions/C/FileHeader.h`` and ``type-definitions/C/FrameHeader.h`` (``#pragma pack(1)``,
little-endian). Field names are the SDK's, so a reader can grep either side. ``scale``/``unit``
give the SI value (``si = raw * scale``) where the SDK documents a unit; the headers themselves
are kept raw (vendor units) by the codecs so that a frame re-encodes byte for byte.

Both headers become numpy structured dtypes (:data:`FILE_HEADER_DTYPE`, :data:`FRAME_HEADER_DTYPE`);
a header is read with ``numpy.frombuffer`` without copying and written back with ``tobytes()``.

Beam angle tables: the SDK's ``beam-width-metrics/BeamWidths_*.h`` (beam centre, left, right in
degrees per SDK beam number), transcribed into ``auvlink/data/aris_beam_angles.json`` with the
source file and commit of each table.

The tables live beside the framer, which reads the frame header's layout (signature, ping mode, samples
per beam) to cut frames; the codecs (:mod:`auvlink.codecs.aris`, :mod:`auvlink.codecs.didson`) import them
from here, so framing never imports codecs.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Sequence
from importlib import resources

import numpy as np
import numpy.typing as npt

from auvlink.errors import DecodeError
from auvlink.fields import Field

#: ``'DDF'`` + format version 5 (DDF_05), first 4 bytes of a file and bytes 12..16 of a frame header
SIGNATURE = b"DDF\x05"
SIGNATURE_U32 = 0x05464444
FILE_HEADER_SIZE = 1024
FRAME_HEADER_SIZE = 1024

_US = 1e-6  # microseconds -> s
_DEG = 0.017453292519943295  # degrees -> rad
_PSI = 6894.757293168361  # psi -> Pa
_MV = 1e-3  # mV -> V

FILE_HEADER_FIELDS: tuple[Field, ...] = (
    Field("Version", "I"),  # DDF_05 = 0x05464444
    Field("FrameCount", "I"),  # writers fill it; readers derive the count from the file size
    Field("FrameRate", "I"),  # obsolete
    Field("HighResolution", "I"),  # obsolete
    Field("NumRawBeams", "I"),  # ARIS 3000 = 128/64, 1800 = 96/48, 1200 = 48
    Field("SampleRate", "f"),  # obsolete
    Field("SamplesPerChannel", "I"),
    Field("ReceiverGain", "I"),  # obsolete
    Field("WindowStart", "f", 1.0, "m"),  # obsolete
    Field("WindowLength", "f", 1.0, "m"),  # obsolete
    Field("Reverse", "I"),  # obsolete
    Field("SN", "I"),  # sonar serial number
    Field("strDate", "32s"),
    Field("strHeaderID", "256s"),
    *(Field(f"UserID{i}", "i") for i in range(1, 5)),
    Field("StartFrame", "I"),
    Field("EndFrame", "I"),
    Field("TimeLapse", "I"),
    Field("RecordInterval", "I"),
    Field("RadioSeconds", "I"),
    Field("FrameInterval", "I"),
    Field("Flags", "I"),
    Field("AuxFlags", "I"),
    Field("Sspd", "I", 1.0, "m/s"),  # obsolete
    Field("Flags3D", "I"),
    Field("SoftwareVersion", "I"),
    Field("WaterTemp", "I"),  # code: 0 = 5-15 C, 1 = 15-25 C, 2 = 25-35 C
    Field("Salinity", "I"),  # code: 0 fresh, 1 brackish, 2 salt
    Field("PulseLength", "I"),
    Field("TxMode", "I"),
    Field("VersionFGPA", "I"),
    Field("VersionPSuC", "I"),
    Field("ThumbnailFI", "I"),
    Field("FileSize", "Q"),  # obsolete
    Field("OptionalHeaderSize", "Q"),  # obsolete
    Field("OptionalTailSize", "Q"),  # obsolete
    Field("VersionMinor", "I"),  # obsolete
    Field("LargeLens", "I"),  # obsolete (see the frame header)
    Field("padding", "568x"),  # kept verbatim
)

_FAULTS = ("FocusTimeout", "FocusOverCurrent", "FocusNotFound", "FocusStalled", "FPGATimeout",
           "FPGABusy", "FPGAStuck", "CPUTemp", "PSUTemp", "WaterTemp", "Humidity", "Pressure",
           "VoltageRead", "VoltageWrite")

FRAME_HEADER_FIELDS: tuple[Field, ...] = (
    Field("FrameIndex", "I"),
    Field("FrameTime", "Q", _US, "s"),  # PC time stamp, us since 1970-01-01
    Field("Version", "I"),  # 0x05464444
    Field("Status", "I"),
    Field("sonarTimeStamp", "Q", _US, "s"),  # on-sonar us since 1970-01-01
    Field("TS_Day", "I"),
    Field("TS_Hour", "I"),
    Field("TS_Minute", "I"),
    Field("TS_Second", "I"),
    Field("TS_Hsecond", "I"),
    Field("TransmitMode", "I"),
    Field("WindowStart", "f", 1.0, "m"),
    Field("WindowLength", "f", 1.0, "m"),
    Field("Threshold", "I"),
    Field("Intensity", "i"),
    Field("ReceiverGain", "I"),  # dB 0..24
    Field("DegC1", "I"),  # CPU temperature, degC
    Field("DegC2", "I"),  # power supply temperature, degC
    Field("Humidity", "I"),  # % relative
    Field("Focus", "I"),  # focus units 0..1000
    Field("Battery", "I"),  # obsolete
    *(Field(f"UserValue{i}", "f") for i in range(1, 9)),
    Field("Velocity", "f"),  # platform values from an AUV integration (units not given by the SDK)
    Field("Depth", "f"),
    Field("Altitude", "f"),
    Field("Pitch", "f", _DEG, "rad"),
    Field("PitchRate", "f"),
    Field("Roll", "f", _DEG, "rad"),
    Field("RollRate", "f"),
    Field("Heading", "f", _DEG, "rad"),
    Field("HeadingRate", "f"),
    Field("CompassHeading", "f", _DEG, "rad"),
    Field("CompassPitch", "f", _DEG, "rad"),
    Field("CompassRoll", "f", _DEG, "rad"),
    Field("Latitude", "d"),
    Field("Longitude", "d"),
    Field("SonarPosition", "f"),
    Field("ConfigFlags", "I"),
    Field("BeamTilt", "f"),
    Field("TargetRange", "f"),
    Field("TargetBearing", "f"),
    Field("TargetPresent", "I"),
    Field("FirmwareRevision", "I"),  # obsolete
    Field("Flags", "I"),
    Field("SourceFrame", "I"),
    Field("WaterTemp", "f", 1.0, "degC"),
    Field("TimerPeriod", "I"),
    Field("SonarX", "f"),
    Field("SonarY", "f"),
    Field("SonarZ", "f"),
    Field("SonarPan", "f"),
    Field("SonarTilt", "f"),
    Field("SonarRoll", "f"),
    Field("PanPNNL", "f"),
    Field("TiltPNNL", "f"),
    Field("RollPNNL", "f"),
    Field("VehicleTime", "d"),
    Field("TimeGGK", "f"),
    Field("DateGGK", "I"),
    Field("QualityGGK", "I"),
    Field("NumSatsGGK", "I"),
    Field("DOPGGK", "f"),
    Field("EHTGGK", "f"),
    Field("HeaveTSS", "f"),
    *(Field(f"{unit}GPS", "I") for unit in ("Year", "Month", "Day", "Hour", "Minute", "Second")),
    Field("HSecondGPS", "I"),
    *(Field(f"Sonar{axis}Offset", "f") for axis in ("Pan", "Tilt", "Roll", "X", "Y", "Z")),
    Field("Tmatrix", "16f"),
    Field("SampleRate", "f", 1.0, "Hz"),  # 1e6 / SamplePeriod
    Field("AccellX", "f"),
    Field("AccellY", "f"),
    Field("AccellZ", "f"),
    Field("PingMode", "I"),  # 1..12, gives the beam count
    Field("FrequencyHiLow", "I"),  # 1 = HF, 0 = LF
    Field("PulseWidth", "I", _US, "s"),
    Field("CyclePeriod", "I", _US, "s"),
    Field("SamplePeriod", "I", _US, "s"),
    Field("TransmitEnable", "I"),
    Field("FrameRate", "f"),
    Field("SoundSpeed", "f", 1.0, "m/s"),
    Field("SamplesPerBeam", "I"),
    Field("Enable150V", "I"),
    Field("SampleStartDelay", "I", _US, "s"),
    Field("LargeLens", "I"),  # 1 = telephoto lens
    Field("TheSystemType", "I"),  # 1 = ARIS 3000, 0 = ARIS 1800, 2 = ARIS 1200
    Field("SonarSerialNumber", "I"),
    Field("ReservedEK", "Q"),  # obsolete
    Field("ArisErrorFlagsUint", "I"),
    Field("MissedPackets", "I"),
    Field("ArisAppVersion", "I"),
    Field("Available2", "I"),
    Field("ReorderedSamples", "I"),  # 1 = samples already in [sample][beam] order
    Field("Salinity", "I"),  # 0 fresh, 15 brackish, 35 salt
    Field("Pressure", "f", _PSI, "Pa"),
    Field("BatteryVoltage", "f", _MV, "V"),
    Field("MainVoltage", "f", _MV, "V"),
    Field("SwitchVoltage", "f", _MV, "V"),
    Field("FocusMotorMoving", "I"),
    Field("VoltageChanging", "I"),
    *(Field(f"{name}Fault", "I") for name in _FAULTS),
    Field("FocusCurrentPosition", "I"),
    Field("TargetPan", "f"),
    Field("TargetTilt", "f"),
    Field("TargetRoll", "f"),
    Field("PanMotorErrorCode", "I"),
    Field("TiltMotorErrorCode", "I"),
    Field("RollMotorErrorCode", "I"),
    Field("PanAbsPosition", "f"),
    Field("TiltAbsPosition", "f"),
    Field("RollAbsPosition", "f"),
    *(Field(f"{arm}Accel{axis}", "f") for arm in ("Pan", "Tilt", "Roll") for axis in "XYZ"),
    Field("AppliedSettings", "I"),
    Field("ConstrainedSettings", "I"),
    Field("InvalidSettings", "I"),
    Field("EnableInterpacketDelay", "I"),
    Field("InterpacketDelayPeriod", "I"),
    Field("Uptime", "I", 1.0, "s"),
    Field("ArisAppVersionMajor", "H"),
    Field("ArisAppVersionMinor", "H"),
    Field("GoTime", "Q"),
    Field("PanVelocity", "f", _DEG, "rad/s"),
    Field("TiltVelocity", "f", _DEG, "rad/s"),
    Field("RollVelocity", "f", _DEG, "rad/s"),
    Field("GpsTimeAge", "I", _US, "s"),
    Field("SystemVariant", "I"),
    Field("padding", "288x"),  # kept verbatim
)

_NUMPY_CODES = {"I": "<u4", "i": "<i4", "Q": "<u8", "H": "<u2", "f": "<f4", "d": "<f8"}


def _numpy_format(fmt: str) -> str | tuple[str, tuple[int, ...]]:
    count = int(fmt[:-1]) if len(fmt) > 1 else 1
    code = fmt[-1]
    if code == "s":
        return f"S{count}"
    if code == "x":
        return f"V{count}"  # opaque bytes, never interpreted
    base = _NUMPY_CODES[code]
    return (base, (count,)) if count > 1 else base


def structured_dtype(fields: Sequence[Field], size: int) -> np.dtype:
    """A packed little-endian numpy dtype of ``fields``; checks that it is ``size`` bytes long."""
    dtype = np.dtype([(f.name, _numpy_format(f.fmt)) for f in fields])
    if dtype.itemsize != size:
        raise AssertionError(f"field table is {dtype.itemsize} bytes, expected {size}")
    return dtype


FILE_HEADER_DTYPE = structured_dtype(FILE_HEADER_FIELDS, FILE_HEADER_SIZE)
FRAME_HEADER_DTYPE = structured_dtype(FRAME_HEADER_FIELDS, FRAME_HEADER_SIZE)
FRAME_FIELDS = {f.name: f for f in FRAME_HEADER_FIELDS}


def offset(dtype: np.dtype, name: str) -> int:
    """Byte offset of field ``name`` in a header dtype."""
    fields = dtype.fields
    assert fields is not None
    return int(fields[name][1])


#: offsets the framer reads without building a record
OFF_SIGNATURE = offset(FRAME_HEADER_DTYPE, "Version")  # 12
OFF_PING_MODE = offset(FRAME_HEADER_DTYPE, "PingMode")  # 436
OFF_SAMPLES_PER_BEAM = offset(FRAME_HEADER_DTYPE, "SamplesPerBeam")  # 468

#: ping mode -> beam count (aris-file-sdk ``common-code/FrameFuncs.c``, get_beams_from_pingmode)
PING_MODE_BEAMS: dict[int, int] = {
    1: 48, 2: 48,  # ARIS 1200 / 1800
    3: 96, 4: 96, 5: 96,  # ARIS 1800
    6: 64, 7: 64, 8: 64,  # ARIS 3000
    9: 128, 10: 128, 11: 128, 12: 128,  # ARIS 3000
}
#: the largest SamplesPerBeam a header may claim before the framer calls it corrupt
MAX_SAMPLES_PER_BEAM = 8192

# --- beam angle tables (aris-file-sdk beam-width-metrics, in auvlink/data/aris_beam_angles.json) ---
_TABLE_FOR_BEAMS = {48: "ARIS1800_1200_48", 96: "ARIS1800_96", 64: "ARIS3000_64", 128: "ARIS3000_128"}


@functools.cache
def beam_tables() -> dict[str, npt.NDArray[np.float64]]:
    """SDK beam-centre angles in degrees, indexed by SDK beam number, per table name."""
    text = (resources.files("auvlink") / "data" / "aris_beam_angles.json").read_text(encoding="utf-8")
    return {k: np.asarray(t["center_deg"], dtype=np.float64) for k, t in json.loads(text)["tables"].items()}


def beam_table_name(beams: int, large_lens: bool = False) -> str:
    """The SDK beam-width table for a beam count and lens."""
    if large_lens and beams in (48, 96):
        return f"ARIS_Telephoto_{beams}"
    try:
        return _TABLE_FOR_BEAMS[beams]
    except KeyError as exc:
        raise DecodeError(f"aris: no beam table for {beams} beams", fmt="aris") from exc


@functools.cache
def beam_azimuths_rad(beams: int, large_lens: bool = False) -> npt.NDArray[np.float64]:
    """Azimuth (rad, + to starboard) of each image column, column 0 = port-most beam (read-only)."""
    az = np.deg2rad(-beam_tables()[beam_table_name(beams, large_lens)][::-1])
    az.setflags(write=False)
    return az
