"""Records of the Teledyne RDI PD0 codec: one :class:`Pd0Ensemble` per ensemble, in SI units.

Spec: Teledyne RD Instruments, "WorkHorse Commands and Output Data Format", PD0 chapter (field
tables in :mod:`auvlink.codecs.pd0_defs`). Leaders keep every field (None where the block is too
short to hold it); profile and bottom-track velocities are float arrays in m/s with NaN where the
instrument marked them bad (-32768), ranges in m with NaN where there is no bottom (0). Nothing is
lost: data types the codec does not decode are kept raw in :attr:`Pd0Ensemble.other`, and
:class:`Pd0Layout` keeps the section order and any padding, so ``encode(decode(x)) == x``.
Bottom-track velocities follow the PD0 sign convention: the bottom moving relative to the
instrument (PD4/5/6 report the vehicle moving, i.e. the opposite sign).
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from auvlink.codecs._util import ValueEq
from auvlink.codecs.pd0_defs import BEAM_ANGLES_DEG, COORDINATE_SYSTEMS, FREQUENCIES_KHZ

FloatArray = NDArray[np.float64]
ByteArray = NDArray[np.uint8]
Quad = tuple[int, ...]  # one value per beam (4)


@dataclass(frozen=True)
class FixedLeader:
    """Fixed leader (0x0000): the configuration, the same in every ensemble of a deployment."""

    firmware_version: int
    firmware_revision: int
    system_config: int
    simulated: int
    lag_length: int
    n_beams: int
    n_cells: int
    pings_per_ensemble: int
    cell_size_m: float
    blank_m: float
    profiling_mode: int
    low_correlation_threshold: int
    n_code_repetitions: int
    percent_good_min: int
    error_velocity_max_mps: float
    tpp_minutes: int
    tpp_seconds: int
    tpp_hundredths: int
    coord_transform: int
    heading_alignment_rad: float
    heading_bias_rad: float
    sensor_source: int
    sensors_available: int
    bin1_distance_m: float
    transmit_pulse_length_m: float
    ref_layer_start_cell: int
    ref_layer_end_cell: int
    false_target_threshold: int
    spare_39: int
    transmit_lag_distance_m: float
    cpu_board_serial: bytes
    system_bandwidth: int
    system_power: int
    spare_53: int
    serial_number: int
    beam_angle_deg: int | None = None  # absent from 58-byte leaders

    @property
    def coordinate_system(self) -> str:
        """``beam``, ``instrument``, ``ship`` or ``earth`` (EX bits 4-3)."""
        return COORDINATE_SYSTEMS[(self.coord_transform >> 3) & 3]

    @property
    def firmware(self) -> str:
        return f"{self.firmware_version}.{self.firmware_revision:02d}"

    @property
    def frequency_hz(self) -> float:
        return FREQUENCIES_KHZ[self.system_config & 7] * 1e3

    @property
    def convex(self) -> bool:
        return bool(self.system_config & 0x08)

    @property
    def upward(self) -> bool:
        return bool(self.system_config & 0x80)

    @property
    def beam_angle(self) -> float:
        """Beam angle from vertical in rad (the leader's byte, else the system configuration)."""
        deg = self.beam_angle_deg or BEAM_ANGLES_DEG[(self.system_config >> 8) & 3]
        return float(np.deg2rad(deg))

    @property
    def time_between_pings_s(self) -> float:
        return self.tpp_minutes * 60 + self.tpp_seconds + self.tpp_hundredths * 0.01


@dataclass(frozen=True)
class VariableLeader:
    """Variable leader (0x0080): ensemble number, clock, attitude and environment of one ensemble."""

    ensemble_lsb: int
    rtc_year: int
    rtc_month: int
    rtc_day: int
    rtc_hour: int
    rtc_minute: int
    rtc_second: int
    rtc_hundredths: int
    ensemble_msb: int
    bit_result: int
    speed_of_sound_mps: int
    depth_m: float
    heading_rad: float
    pitch_rad: float
    roll_rad: float
    salinity_ppt: int
    temperature_c: float
    mpt_minutes: int
    mpt_seconds: int
    mpt_hundredths: int
    heading_std_rad: float
    pitch_std_rad: float
    roll_std_rad: float
    adc: bytes
    error_status: int
    spare_46: int | None = None  # 65-byte (and 60-byte) leaders from here on
    pressure_pa: float | None = None
    pressure_variance_pa: float | None = None
    spare_56: int | None = None
    y2k_century: int | None = None
    y2k_year: int | None = None
    y2k_month: int | None = None
    y2k_day: int | None = None
    y2k_hour: int | None = None
    y2k_minute: int | None = None
    y2k_second: int | None = None
    y2k_hundredths: int | None = None

    @property
    def ensemble_number(self) -> int:
        return self.ensemble_lsb + (self.ensemble_msb << 16)

    @property
    def time(self) -> dt.datetime | None:
        """UTC time of the ensemble: the Y2K clock where present and set, else the RTC."""
        try:
            if self.y2k_hundredths is not None and self.y2k_century:
                return dt.datetime(self.y2k_century * 100 + (self.y2k_year or 0), self.y2k_month or 0,
                                   self.y2k_day or 0, self.y2k_hour or 0, self.y2k_minute or 0,
                                   self.y2k_second or 0, self.y2k_hundredths * 10_000, dt.UTC)
            year = self.rtc_year + (2000 if self.rtc_year < 80 else 1900)
            return dt.datetime(year, self.rtc_month, self.rtc_day, self.rtc_hour, self.rtc_minute,
                               self.rtc_second, self.rtc_hundredths * 10_000, dt.UTC)
        except ValueError:  # clock not set (month 0 ...)
            return None


@dataclass(frozen=True, eq=False)
class BottomTrack(ValueEq):
    """Bottom track (0x0600). Per-beam arrays/tuples are in beam order 1-4."""

    pings_per_ensemble: int
    delay_before_reacquire: int
    correlation_min: int
    eval_amplitude_min: int
    percent_good_min: int
    mode: int
    error_velocity_max_mps: float
    reserved_12: bytes
    range_m: FloatArray  # (4,) m, NaN where no bottom
    velocity_mps: FloatArray  # (4,) m/s, NaN where bad; PD0 convention (bottom relative to instrument)
    correlation: Quad
    eval_amplitude: Quad
    percent_good: Quad
    ref_layer_min_m: float
    ref_layer_near_m: float
    ref_layer_far_m: float
    ref_velocity_mps: FloatArray  # (4,) m/s, NaN where bad
    ref_correlation: Quad
    ref_intensity: Quad
    ref_percent_good: Quad
    max_depth_m: float
    rssi: Quad
    gain: int
    range_msb: bool = True  # whether the block carries the range MSB bytes (ranges >= 655.36 m)


@dataclass(frozen=True)
class Pd0Layout:
    """How the ensemble was laid out on the wire, so that encode reproduces it byte for byte."""

    order: tuple[int, ...] = ()  # data-type ids in frame order
    padding: tuple[bytes, ...] = ()  # bytes after the decoded content of each section
    spare: int = 0  # header byte 4
    gap: bytes = b""  # bytes between the offsets table and the first data type


@dataclass(frozen=True, eq=False)
class Pd0Ensemble(ValueEq):
    """One PD0 ensemble. Profile arrays are (cells, beams); NaN velocity = bad."""

    fixed: FixedLeader
    variable: VariableLeader
    velocity_mps: FloatArray | None = None
    correlation: ByteArray | None = None  # counts 0-255
    echo_intensity: ByteArray | None = None  # counts (about 0.45 dB each)
    percent_good: ByteArray | None = None  # %
    bottom_track: BottomTrack | None = None
    other: tuple[tuple[int, bytes], ...] = ()  # undecoded data types: (id, raw section bytes)
    layout: Pd0Layout = Pd0Layout()

    @property
    def ensemble_number(self) -> int:
        return self.variable.ensemble_number

    @property
    def time(self) -> dt.datetime | None:
        return self.variable.time

    @property
    def sensor_time(self) -> float | None:
        """Ensemble time in s since the UNIX epoch (UTC), None when the clock is not set."""
        t = self.variable.time
        return None if t is None else t.timestamp()

    @property
    def coordinate_system(self) -> str:
        return self.fixed.coordinate_system

    @property
    def heading_rad(self) -> float:
        return self.variable.heading_rad

    @property
    def pitch_rad(self) -> float:
        return self.variable.pitch_rad

    @property
    def roll_rad(self) -> float:
        return self.variable.roll_rad

    @property
    def temperature_c(self) -> float:
        return self.variable.temperature_c

    @property
    def depth_m(self) -> float:
        return self.variable.depth_m

    @property
    def bt_velocity_mps(self) -> FloatArray:
        """(4,) bottom-track velocity as stored (PD0 sign convention); all NaN without bottom track."""
        return self.bottom_track.velocity_mps if self.bottom_track else np.full(4, np.nan)

    @property
    def bt_range_m(self) -> FloatArray:
        """(4,) slant range to the bottom per beam; NaN where there is none."""
        return self.bottom_track.range_m if self.bottom_track else np.full(4, np.nan)

    @property
    def cell_ranges_m(self) -> FloatArray:
        """Distance of the centre of each depth cell from the transducer along the vertical."""
        f = self.fixed
        return np.asarray(f.bin1_distance_m + f.cell_size_m * np.arange(f.n_cells), dtype=np.float64)

    def raw_sections(self, type_id: int) -> list[bytes]:
        """The raw bytes of every undecoded section with this data-type id (e.g. 0x2022 NMEA)."""
        return [raw for tid, raw in self.other if tid == type_id]
