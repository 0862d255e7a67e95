"""The ARIS frame record and its zero-copy frame codec (used by :mod:`aris` and :mod:`didson`).

Layout and geometry per SoundMetrics aris-file-sdk (see :mod:`auvlink.codecs.aris` for the full
notes): a 1024-byte frame header then ``SamplesPerBeam`` rows of ``beams`` bytes, SDK beam 0 =
right-most. The record keeps the header whole (numpy structured scalar, vendor units) and exposes
SI values as typed read-only attributes computed from it, so ``encode(decode(x)) == x``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar, overload

import numpy as np
import numpy.typing as npt

from auvlink.errors import DecodeError, EncodeError
from auvlink.framing.aris_defs import (
    FRAME_HEADER_DTYPE,
    FRAME_HEADER_SIZE,
    PING_MODE_BEAMS,
    SIGNATURE_U32,
    beam_azimuths_rad,
)

T = TypeVar("T")


class HeaderValue(Generic[T]):
    """A read-only attribute computed from one field of the owner's ``header``."""

    def __init__(self, name: str, convert: Callable[[Any], T]) -> None:
        self.name = name
        self.convert = convert

    @overload
    def __get__(self, obj: None, owner: type | None = None) -> HeaderValue[T]: ...
    @overload
    def __get__(self, obj: object, owner: type | None = None) -> T: ...
    def __get__(self, obj: object | None, owner: type | None = None) -> HeaderValue[T] | T:
        if obj is None:
            return self
        return self.convert(obj.header[self.name])  # type: ignore[attr-defined]


def _us(value: Any) -> float:
    return int(value) * 1e-6


def _radians(value: Any) -> float | None:
    v = float(value)
    return math.radians(v) if math.isfinite(v) else None


def _scalar(value: Any) -> Any:
    return value.item() if isinstance(value, np.generic) else value


@dataclass(frozen=True, eq=False, repr=False)
class ArisFrame:
    """One ARIS frame: the whole header (vendor units) and the image; SI values as attributes."""

    header: np.void
    #: (samples, beams) uint8; row = range bin, column 0 = port-most beam
    image: npt.NDArray[np.uint8]

    def __post_init__(self) -> None:
        h = self.header
        if not isinstance(h, np.void) or h.dtype != FRAME_HEADER_DTYPE:
            raise EncodeError("aris: frame header must be a FRAME_HEADER_DTYPE scalar")
        shape = (int(h["SamplesPerBeam"]), PING_MODE_BEAMS.get(int(h["PingMode"])))
        img = self.image
        if not isinstance(img, np.ndarray) or img.dtype != np.uint8 or img.shape != shape:
            got = (getattr(img, "dtype", type(img)), getattr(img, "shape", None))
            raise EncodeError(f"aris: image must be uint8 of shape {shape} from the header, got {got}")

    def __eq__(self, other: object) -> bool:
        return (
            type(other) is type(self)
            and isinstance(other, ArisFrame)
            and self.header.tobytes() == other.header.tobytes()
            and np.array_equal(self.image, other.image)
        )

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(frame_index={self.frame_index}, time={self.time:.6f}, "
            f"ping_mode={self.ping_mode}, samples x beams={self.image.shape}, "
            f"window={self.window_start_m:.3f}+{self.window_length_m:.3f} m)"
        )

    def field(self, name: str) -> Any:
        """A raw header field by its SDK name (vendor units, Python value)."""
        value = self.header[name]
        return value.tolist() if isinstance(value, np.ndarray) else _scalar(value)

    def header_values(self) -> dict[str, Any]:
        """Every header field except the padding (vendor units)."""
        return {n: self.field(n) for n in self.header.dtype.names or () if n != "padding"}

    frame_index = HeaderValue("FrameIndex", int)
    #: PC time stamp of the frame, s since the UNIX epoch
    time = HeaderValue("FrameTime", _us)
    #: the sonar's own time stamp, s since the UNIX epoch
    sonar_time = HeaderValue("sonarTimeStamp", _us)
    ping_mode = HeaderValue("PingMode", int)
    sound_speed = HeaderValue("SoundSpeed", float)  # m/s
    sample_period = HeaderValue("SamplePeriod", _us)  # s
    sample_start_delay = HeaderValue("SampleStartDelay", _us)  # s
    large_lens = HeaderValue("LargeLens", bool)
    system_type = HeaderValue("TheSystemType", int)  # 0 = ARIS 1800, 1 = ARIS 3000, 2 = ARIS 1200
    samples_reordered = HeaderValue("ReorderedSamples", bool)
    #: platform attitude from an AUV integration (rad), ``None`` where the header holds NaN
    heading = HeaderValue("Heading", _radians)
    pitch = HeaderValue("Pitch", _radians)
    roll = HeaderValue("Roll", _radians)

    @property
    def beam_count(self) -> int:
        return int(self.image.shape[1])

    @property
    def samples_per_beam(self) -> int:
        return int(self.image.shape[0])

    @property
    def range_resolution_m(self) -> float:
        """Spacing of the range bins (m): SamplePeriod * SoundSpeed / 2."""
        return self.sample_period * self.sound_speed / 2.0

    @property
    def window_start_m(self) -> float:
        """Range of the first bin (m): SampleStartDelay * SoundSpeed / 2."""
        return self.sample_start_delay * self.sound_speed / 2.0

    @property
    def window_length_m(self) -> float:
        return self.range_resolution_m * self.samples_per_beam

    @functools.cached_property
    def ranges_m(self) -> npt.NDArray[np.float64]:
        """Range of each image row (m): window start + row * range resolution."""
        bins = np.arange(self.samples_per_beam, dtype=np.float64)
        r = (self.window_start_m + bins * self.range_resolution_m).astype(np.float64)
        r.setflags(write=False)
        return r

    @functools.cached_property
    def azimuths_rad(self) -> npt.NDArray[np.float64]:
        """Azimuth of each image column (rad, + to starboard) from the SDK beam table."""
        return beam_azimuths_rad(self.beam_count, self.large_lens)


F = TypeVar("F", bound=ArisFrame)


def decode_as(raw: bytes | bytearray | memoryview, cls: type[F], fmt: str = "aris") -> F:
    """Decode one frame into ``cls`` (:class:`ArisFrame` or a subclass); the image views ``raw``."""
    if len(raw) < FRAME_HEADER_SIZE:
        raise DecodeError(f"{fmt}: {len(raw)} bytes, shorter than a frame header", fmt=fmt)
    header = np.frombuffer(raw, FRAME_HEADER_DTYPE, count=1)[0]
    if int(header["Version"]) != SIGNATURE_U32:
        raise DecodeError(f"{fmt}: frame signature 0x{int(header['Version']):08X}, expected DDF_05", fmt=fmt)
    beams = PING_MODE_BEAMS.get(int(header["PingMode"]))
    if beams is None:
        raise DecodeError(f"{fmt}: unknown ping mode {int(header['PingMode'])}", fmt=fmt)
    samples = int(header["SamplesPerBeam"])
    if samples < 1 or len(raw) != FRAME_HEADER_SIZE + beams * samples:
        raise DecodeError(
            f"{fmt}: frame is {len(raw)} bytes, header says 1024 + {beams} beams x {samples} samples", fmt=fmt
        )
    wire = np.frombuffer(raw, np.uint8, count=beams * samples, offset=FRAME_HEADER_SIZE)
    try:
        return cls(header, wire.reshape(samples, beams)[:, ::-1])
    except EncodeError as exc:  # a subclass refusing this frame (e.g. DIDSON: 96 beams only)
        raise DecodeError(f"{fmt}: {exc}", fmt=fmt) from exc


def encode_frame(frame: ArisFrame) -> bytes:
    """Frame -> raw bytes: the header verbatim, then the image in the SDK beam order."""
    return frame.header.tobytes() + frame.image[:, ::-1].tobytes()
