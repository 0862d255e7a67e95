"""Build new PD0 ensembles from scratch (the simulator's side of :mod:`auvlink.codecs.pd0`).

Spec: Teledyne RD Instruments, "WorkHorse Commands and Output Data Format", PD0 chapter. The
defaults describe a down-looking 600 kHz Workhorse: 4 beams at 20 degrees, convex, firmware
51.41, bottom track on. :func:`build` returns exactly what a receiver decodes from the encoded
bytes (every value quantized to its wire resolution), so ``decode(encode(build(...)))`` equals it.
"""

from __future__ import annotations

import datetime as dt
import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from auvlink.codecs import pd0_defs as d
from auvlink.codecs.pd0 import decode, encode
from auvlink.codecs.pd0_records import BottomTrack, FixedLeader, Pd0Ensemble, Pd0Layout, VariableLeader
from auvlink.errors import EncodeError

_NAN4 = (math.nan,) * 4


def _utc(time: dt.datetime | float) -> dt.datetime:
    """Any time -> aware UTC datetime rounded to the clock's hundredths of a second."""
    if isinstance(time, dt.datetime):
        t = time if time.tzinfo else time.replace(tzinfo=dt.UTC)
        epoch = t.timestamp()
    else:
        epoch = float(time)
    cs = round(epoch * 100)
    epoch0 = dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
    return epoch0 + dt.timedelta(seconds=cs // 100, milliseconds=cs % 100 * 10)


def _system_config(frequency_khz: int, beam_angle_deg: int, convex: bool, upward: bool) -> int:
    try:
        freq = d.FREQUENCIES_KHZ.index(frequency_khz)
    except ValueError as exc:
        raise EncodeError(f"pd0: no PD0 code for {frequency_khz} kHz") from exc
    angle = d.BEAM_ANGLES_DEG.index(beam_angle_deg) if beam_angle_deg in d.BEAM_ANGLES_DEG[:3] else 3
    lsb = freq | (0x08 if convex else 0) | 0x40 | (0x80 if upward else 0)  # 0x40: transducer attached
    return lsb | (angle | 0x40) << 8  # 0x40 in the MSB: 4-beam janus


def _quad(values: ArrayLike | None, default: tuple[int, ...]) -> tuple[int, ...]:
    return default if values is None else tuple(int(v) for v in np.asarray(values).reshape(4))


def build(
    ensemble_number: int,
    time: dt.datetime | float,
    *,
    heading_rad: float = 0.0,
    pitch_rad: float = 0.0,
    roll_rad: float = 0.0,
    temperature_c: float = 10.0,
    depth_m: float = 0.0,
    pressure_pa: float = 0.0,
    salinity_ppt: int = 35,
    speed_of_sound_mps: int = 1500,
    bt_velocity_mps: ArrayLike | None = None,
    bt_range_m: ArrayLike | None = None,
    bt_correlation: ArrayLike | None = None,
    bt_eval_amplitude: ArrayLike | None = None,
    bt_percent_good: ArrayLike | None = None,
    coordinate_system: str = "instrument",
    velocity_mps: ArrayLike | None = None,
    correlation: ArrayLike | None = None,
    echo_intensity: ArrayLike | None = None,
    percent_good: ArrayLike | None = None,
    n_cells: int | None = None,
    cell_size_m: float = 1.0,
    blank_m: float = 0.88,
    bin1_distance_m: float | None = None,
    frequency_khz: int = 600,
    beam_angle_deg: int = 20,
    convex: bool = True,
    upward: bool = False,
    serial_number: int = 0,
    firmware: tuple[int, int] = (51, 41),
    bottom_track: bool | None = None,
) -> Pd0Ensemble:
    """A new ensemble. Angles in rad, velocities in m/s (NaN = bad), ranges in m (NaN = no bottom).

    Bottom track is included when ``bottom_track`` is True, or by default when ``bt_velocity_mps``
    or ``bt_range_m`` is given. Profile arrays are (cells, 4); each is included when given.
    """
    if coordinate_system not in d.COORDINATE_SYSTEMS:
        raise EncodeError(f"pd0: coordinate system must be one of {d.COORDINATE_SYSTEMS}")
    profiles = {"velocity_mps": velocity_mps, "correlation": correlation,
                "echo_intensity": echo_intensity, "percent_good": percent_good}
    arrays = {k: np.asarray(v, dtype=np.float64) for k, v in profiles.items() if v is not None}
    for name, a in arrays.items():
        if a.ndim != 2 or a.shape[1] != 4:
            raise EncodeError(f"pd0: {name} must be (cells, 4), got {a.shape}")
        if name != "velocity_mps" and (np.isnan(a).any() or a.min(initial=0) < 0 or a.max(initial=0) > 255):
            raise EncodeError(f"pd0: {name} must hold integers 0..255")
    cells = n_cells if n_cells is not None else next((a.shape[0] for a in arrays.values()), 30)
    coord = d.COORDINATE_SYSTEMS.index(coordinate_system)
    fixed = FixedLeader(
        firmware_version=firmware[0], firmware_revision=firmware[1],
        system_config=_system_config(frequency_khz, beam_angle_deg, convex, upward),
        simulated=0, lag_length=53, n_beams=4, n_cells=cells, pings_per_ensemble=1,
        cell_size_m=cell_size_m, blank_m=blank_m, profiling_mode=1, low_correlation_threshold=64,
        n_code_repetitions=5, percent_good_min=0, error_velocity_max_mps=2.0,
        tpp_minutes=0, tpp_seconds=0, tpp_hundredths=50,
        coord_transform=coord << 3 | (0x07 if coord else 0), heading_alignment_rad=0.0,
        heading_bias_rad=0.0, sensor_source=0x7D, sensors_available=0x3D,
        bin1_distance_m=blank_m + cell_size_m if bin1_distance_m is None else bin1_distance_m,
        transmit_pulse_length_m=cell_size_m, ref_layer_start_cell=1, ref_layer_end_cell=5,
        false_target_threshold=50, spare_39=0, transmit_lag_distance_m=0.24,
        cpu_board_serial=bytes(8), system_bandwidth=0, system_power=255, spare_53=0,
        serial_number=serial_number, beam_angle_deg=beam_angle_deg,
    )
    t = _utc(time)
    heading_deg = math.degrees(heading_rad) % 360.0
    if round(heading_deg * 100) >= 36000:
        heading_deg = 0.0
    variable = VariableLeader(
        ensemble_lsb=ensemble_number & 0xFFFF, rtc_year=t.year % 100, rtc_month=t.month,
        rtc_day=t.day, rtc_hour=t.hour, rtc_minute=t.minute, rtc_second=t.second,
        rtc_hundredths=t.microsecond // 10_000, ensemble_msb=ensemble_number >> 16, bit_result=0,
        speed_of_sound_mps=speed_of_sound_mps, depth_m=depth_m, heading_rad=math.radians(heading_deg),
        pitch_rad=pitch_rad, roll_rad=roll_rad, salinity_ppt=salinity_ppt, temperature_c=temperature_c,
        mpt_minutes=0, mpt_seconds=0, mpt_hundredths=0, heading_std_rad=0.0, pitch_std_rad=0.0,
        roll_std_rad=0.0, adc=bytes(8), error_status=0, spare_46=0, pressure_pa=pressure_pa,
        pressure_variance_pa=0.0, spare_56=0, y2k_century=t.year // 100, y2k_year=t.year % 100,
        y2k_month=t.month, y2k_day=t.day, y2k_hour=t.hour, y2k_minute=t.minute, y2k_second=t.second,
        y2k_hundredths=t.microsecond // 10_000,
    )
    with_bt = bt_velocity_mps is not None or bt_range_m is not None if bottom_track is None else bottom_track
    bt = None
    if with_bt:
        vel = np.asarray(_NAN4 if bt_velocity_mps is None else bt_velocity_mps, dtype=np.float64).reshape(4)
        good = tuple(0 if math.isnan(v) else 1 for v in vel.tolist())
        bt = BottomTrack(
            pings_per_ensemble=1, delay_before_reacquire=0, correlation_min=220, eval_amplitude_min=30,
            percent_good_min=0, mode=5, error_velocity_max_mps=1.0, reserved_12=bytes(4),
            range_m=np.asarray(_NAN4 if bt_range_m is None else bt_range_m, dtype=np.float64).reshape(4),
            velocity_mps=vel,
            correlation=_quad(bt_correlation, tuple(255 * g for g in good)),
            eval_amplitude=_quad(bt_eval_amplitude, tuple(80 * g for g in good)),
            percent_good=_quad(bt_percent_good, tuple(100 * g for g in good)),
            ref_layer_min_m=8.0, ref_layer_near_m=16.0, ref_layer_far_m=24.0,
            ref_velocity_mps=np.full(4, np.nan), ref_correlation=(0, 0, 0, 0), ref_intensity=(0, 0, 0, 0),
            ref_percent_good=(0, 0, 0, 0), max_depth_m=100.0, rssi=(0, 0, 0, 0), gain=0, range_msb=True,
        )
    kw: dict[str, Any] = {k: (a if k == "velocity_mps" else a.astype(np.uint8)) for k, a in arrays.items()}
    order = [d.FIXED_LEADER_ID, d.VARIABLE_LEADER_ID]
    order += [tid for tid, name in ((d.VELOCITY_ID, "velocity_mps"), (d.CORRELATION_ID, "correlation"),
                                    (d.ECHO_INTENSITY_ID, "echo_intensity"),
                                    (d.PERCENT_GOOD_ID, "percent_good")) if name in kw]
    padding = [b""] * len(order)
    if bt is not None:
        order.append(d.BOTTOM_TRACK_ID)
        padding.append(bytes(4))  # the 4 reserved bytes after the range MSBs (85-byte block)
    draft = Pd0Ensemble(fixed=fixed, variable=variable, bottom_track=bt,
                        layout=Pd0Layout(order=tuple(order), padding=tuple(padding)), **kw)
    return decode(encode(draft))
