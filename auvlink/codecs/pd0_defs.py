"""Field tables of the Teledyne RDI PD0 ensemble (declarative; compiled once at import).

Spec: Teledyne RD Instruments, "WorkHorse Commands and Output Data Format" (P/N 957-6156-00),
chapter "PD0 Output Format": header (0x7F7F), fixed leader (0x0000), variable leader (0x0080),
velocity (0x0100), correlation magnitude (0x0200), echo intensity (0x0300), percent good (0x0400)
and bottom track (0x0600). All fields little-endian. Offsets below are 0-based.

Leaders differ in length between firmware: the fixed leader is 58 or 59 bytes (beam angle byte),
the variable leader 46 (up to the error status word), 60 (glider firmware) or 65 bytes (pressure
and the Y2K clock). :func:`prefix_layout` compiles the longest run of fields that fits a block;
the fields beyond it are ``None`` in the record and the bytes beyond them are kept raw.

Scales turn the wire integer into SI (``value = raw * scale``); every scale is chosen so that
``round(value / scale)`` gives the raw integer back, which is what makes encode exact.
"""

from __future__ import annotations

import math
import struct
from functools import lru_cache
from typing import Any

import numpy as np

from auvlink.fields import Field, Layout

HEADER_ID = 0x7F7F
WAVES_ID = 0x7F79  # WorkHorse waves records in the same stream: same length + checksum rule
FIXED_LEADER_ID = 0x0000
VARIABLE_LEADER_ID = 0x0080
VELOCITY_ID = 0x0100
CORRELATION_ID = 0x0200
ECHO_INTENSITY_ID = 0x0300
PERCENT_GOOD_ID = 0x0400
BOTTOM_TRACK_ID = 0x0600

#: velocity (profile and bottom track) that the instrument marks bad
BAD_VELOCITY = -32768
#: the header: 0x7F, data source id (0x7F), nbytes (without the 2-byte checksum), spare, n data types
HEADER = struct.Struct("<BBHBB")
HEADER_SIZE = HEADER.size

CDEG = 0.01 * math.pi / 180.0  # 0.01 degree -> rad
DDEG = 0.1 * math.pi / 180.0  # 0.1 degree -> rad
DEG = math.pi / 180.0

#: bits 4-3 of the fixed leader's coordinate-transform byte (EX command)
COORDINATE_SYSTEMS = ("beam", "instrument", "ship", "earth")
#: system configuration bits 2-0 -> frequency in kHz
FREQUENCIES_KHZ = (75, 150, 300, 600, 1200, 2400, 38, 0)
#: system configuration bits 9-8 -> beam angle in degrees (0: "other", see the leader's beam angle)
BEAM_ANGLES_DEG = (15, 20, 30, 0)

FIXED_LEADER = (
    Field("id", "H"),
    Field("firmware_version", "B"),
    Field("firmware_revision", "B"),
    Field("system_config", "H"),  # frequency, convex, sensor config, up/down, beam angle, beams
    Field("simulated", "B"),  # real (0) / simulated (1) data flag
    Field("lag_length", "B"),
    Field("n_beams", "B"),
    Field("n_cells", "B"),  # WN
    Field("pings_per_ensemble", "H"),  # WP
    Field("cell_size_m", "H", 0.01, "m"),  # WS, cm
    Field("blank_m", "H", 0.01, "m"),  # WF, cm
    Field("profiling_mode", "B"),  # WM
    Field("low_correlation_threshold", "B"),  # WC
    Field("n_code_repetitions", "B"),
    Field("percent_good_min", "B"),  # WG
    Field("error_velocity_max_mps", "H", 0.001, "m/s"),  # WE, mm/s
    Field("tpp_minutes", "B"),  # TP: time between pings
    Field("tpp_seconds", "B"),
    Field("tpp_hundredths", "B"),
    Field("coord_transform", "B"),  # EX: bits 4-3 frame, bit 2 tilts, bit 1 3-beam, bit 0 bin map
    Field("heading_alignment_rad", "h", CDEG, "rad"),  # EA, 0.01 deg
    Field("heading_bias_rad", "h", CDEG, "rad"),  # EB, 0.01 deg
    Field("sensor_source", "B"),  # EZ
    Field("sensors_available", "B"),
    Field("bin1_distance_m", "H", 0.01, "m"),  # cm
    Field("transmit_pulse_length_m", "H", 0.01, "m"),  # WT, cm
    Field("ref_layer_start_cell", "B"),  # WL
    Field("ref_layer_end_cell", "B"),
    Field("false_target_threshold", "B"),  # WA
    Field("spare_39", "B"),
    Field("transmit_lag_distance_m", "H", 0.01, "m"),  # cm
    Field("cpu_board_serial", "8s"),
    Field("system_bandwidth", "H"),  # WB
    Field("system_power", "B"),  # CQ
    Field("spare_53", "B"),
    Field("serial_number", "I"),
    Field("beam_angle_deg", "B"),  # 59-byte leaders only
)

VARIABLE_LEADER = (
    Field("id", "H"),
    Field("ensemble_lsb", "H"),
    Field("rtc_year", "B"),  # two digits
    Field("rtc_month", "B"),
    Field("rtc_day", "B"),
    Field("rtc_hour", "B"),
    Field("rtc_minute", "B"),
    Field("rtc_second", "B"),
    Field("rtc_hundredths", "B"),
    Field("ensemble_msb", "B"),  # rollover counter of the ensemble number
    Field("bit_result", "H"),
    Field("speed_of_sound_mps", "H", 1.0, "m/s"),
    Field("depth_m", "H", 0.1, "m"),  # depth of transducer, dm
    Field("heading_rad", "H", CDEG, "rad"),
    Field("pitch_rad", "h", CDEG, "rad"),
    Field("roll_rad", "h", CDEG, "rad"),
    Field("salinity_ppt", "H", 1.0, "ppt"),
    Field("temperature_c", "h", 0.01, "degC"),
    Field("mpt_minutes", "B"),  # minimum pre-ping wait
    Field("mpt_seconds", "B"),
    Field("mpt_hundredths", "B"),
    Field("heading_std_rad", "B", DEG, "rad"),  # 1 deg
    Field("pitch_std_rad", "B", DDEG, "rad"),  # 0.1 deg
    Field("roll_std_rad", "B", DDEG, "rad"),  # 0.1 deg
    Field("adc", "8s"),  # ADC channels 0-7
    Field("error_status", "I"),  # end of the 46-byte leader
    Field("spare_46", "H"),
    Field("pressure_pa", "I", 10.0, "Pa"),  # deca-pascals
    Field("pressure_variance_pa", "I", 10.0, "Pa"),
    Field("spare_56", "B"),
    Field("y2k_century", "B"),
    Field("y2k_year", "B"),
    Field("y2k_month", "B"),
    Field("y2k_day", "B"),
    Field("y2k_hour", "B"),
    Field("y2k_minute", "B"),
    Field("y2k_second", "B"),
    Field("y2k_hundredths", "B"),
)

#: bottom track up to the gain byte (77 bytes); per-beam quantities are four consecutive fields
BOTTOM_TRACK = (
    Field("id", "H"),
    Field("pings_per_ensemble", "H"),  # BP
    Field("delay_before_reacquire", "H"),  # BD
    Field("correlation_min", "B"),  # BC
    Field("eval_amplitude_min", "B"),  # BA
    Field("percent_good_min", "B"),  # BG
    Field("mode", "B"),  # BM
    Field("error_velocity_max_mps", "H", 0.001, "m/s"),  # BE, mm/s
    Field("reserved_12", "4s"),
    *(Field(f"range_lsb_{k}", "H", 1.0, "cm") for k in range(4)),
    *(Field(f"velocity_{k}", "h", 1.0, "mm/s") for k in range(4)),
    *(Field(f"correlation_{k}", "B") for k in range(4)),
    *(Field(f"eval_amplitude_{k}", "B") for k in range(4)),
    *(Field(f"percent_good_{k}", "B") for k in range(4)),
    Field("ref_layer_min_m", "H", 0.1, "m"),  # BL, dm
    Field("ref_layer_near_m", "H", 0.1, "m"),
    Field("ref_layer_far_m", "H", 0.1, "m"),
    *(Field(f"ref_velocity_{k}", "h", 1.0, "mm/s") for k in range(4)),
    *(Field(f"ref_correlation_{k}", "B") for k in range(4)),
    *(Field(f"ref_intensity_{k}", "B") for k in range(4)),
    *(Field(f"ref_percent_good_{k}", "B") for k in range(4)),
    Field("max_depth_m", "H", 0.1, "m"),  # BX, dm
    *(Field(f"rssi_{k}", "B") for k in range(4)),
    Field("gain", "B"),
)
#: the range MSB bytes (one per beam) that follow the gain where the block is long enough
BT_RANGE_MSB = struct.Struct("<4B")
BT_BASE = Layout("<", BOTTOM_TRACK)
BT_BASE_SIZE = BT_BASE.size  # 77
BT_MSB_END = BT_BASE_SIZE + BT_RANGE_MSB.size  # 81

# slices of the flat BT tuple (struct order) for each per-beam quantity
_BT_INDEX = {name: i for i, name in enumerate(BT_BASE.names)}
BT_RANGE = slice(_BT_INDEX["range_lsb_0"], _BT_INDEX["range_lsb_0"] + 4)
BT_VELOCITY = slice(_BT_INDEX["velocity_0"], _BT_INDEX["velocity_0"] + 4)
BT_REF_VELOCITY = slice(_BT_INDEX["ref_velocity_0"], _BT_INDEX["ref_velocity_0"] + 4)
BT_BYTE_QUADS = ("correlation", "eval_amplitude", "percent_good", "ref_correlation", "ref_intensity",
                 "ref_percent_good", "rssi")
BT_QUAD_SLICES = {q: slice(_BT_INDEX[f"{q}_0"], _BT_INDEX[f"{q}_0"] + 4) for q in BT_BYTE_QUADS}
_BT_PER_BEAM = {f"{q}_{k}" for q in (*BT_BYTE_QUADS, "range_lsb", "velocity", "ref_velocity")
                for k in range(4)}
#: BT scalar fields (SI name, index in the flat tuple, scale or None)
BT_SCALARS = tuple(
    (f.name, i, None if f.is_raw else f.scale)
    for i, f in enumerate(BOTTOM_TRACK)
    if f.name != "id" and f.name not in _BT_PER_BEAM
)

#: dtypes of the profile arrays (cells x beams after the 2-byte id)
VELOCITY_DTYPE = np.dtype("<i2")
VELOCITY_U16 = np.dtype("<u2")
BYTE_DTYPE = np.dtype("u1")
#: m/s for every int16 velocity read as uint16 (one ``take`` converts a profile; NaN where bad)
VELOCITY_LUT = np.arange(65536, dtype=np.float64)
VELOCITY_LUT[32768:] -= 65536.0
VELOCITY_LUT /= 1000.0
VELOCITY_LUT[BAD_VELOCITY & 0xFFFF] = np.nan
VELOCITY_LUT.flags.writeable = False

_TABLES = {"fixed": FIXED_LEADER, "variable": VARIABLE_LEADER}


class PrefixLayout:
    """The first ``count`` fields of a table compiled into one struct, with their SI scales."""

    def __init__(self, fields: tuple[Field, ...]) -> None:
        self.layout = Layout("<", fields)
        self.struct = self.layout.struct
        self.size = self.layout.size
        self.count = len(fields)
        self.names = self.layout.names
        #: record field names (the id dropped) and (index, scale) of the scaled ones among them
        self.record_names = self.names[1:]
        self.scaled_fields = tuple((i, f.scale) for i, f in enumerate(fields[1:]) if not f.is_raw)

    def scaled(self, raw: tuple[Any, ...]) -> list[Any]:
        """Raw struct values (id first) -> record values (id dropped, scales applied)."""
        values = list(raw[1:])
        for i, scale in self.scaled_fields:
            values[i] *= scale
        return values


@lru_cache(maxsize=64)
def prefix_layout(table: str, nbytes: int) -> PrefixLayout:
    """The longest run of fields of ``table`` ("fixed" / "variable") that fits in ``nbytes``."""
    fields = _TABLES[table]
    total = 0
    count = 0
    for f in fields:
        size = struct.calcsize("<" + f.fmt)
        if total + size > nbytes:
            break
        total += size
        count += 1
    return PrefixLayout(fields[:count])


@lru_cache(maxsize=64)
def layout_of_count(table: str, count: int) -> PrefixLayout:
    """The first ``count`` fields of ``table`` (encode side: count = fields present in a record)."""
    return PrefixLayout(_TABLES[table][:count])


def table_names(table: str) -> tuple[str, ...]:
    """Field names of a table, id excluded (the record's field order)."""
    return tuple(f.name for f in _TABLES[table][1:])
