"""Section-level PD0 work behind :mod:`auvlink.codecs.pd0`: one data type <-> one record part.

Spec: Teledyne RD Instruments, "WorkHorse Commands and Output Data Format", PD0 chapter; field
tables in :mod:`auvlink.codecs.pd0_defs`. Decoders build SI record parts with
:func:`~auvlink.codecs._util.fast_new` (no ``__init__`` in the hot path); encoders invert them
exactly (``round(value / scale)`` gives every raw integer back).
"""

from __future__ import annotations

import math
import struct
from operator import itemgetter
from typing import Any

import numpy as np

from auvlink.codecs import pd0_defs as d
from auvlink.codecs._util import fast_new
from auvlink.codecs.pd0_records import BottomTrack, FixedLeader, Pd0Ensemble, VariableLeader
from auvlink.errors import DecodeError, EncodeError

U16 = struct.Struct("<H")
OFFSETS = [struct.Struct(f"<{n}H") for n in range(256)]
_FIXED_CACHE: dict[bytes, FixedLeader] = {}  # fixed leaders repeat: decode each distinct one once
_PLANS: dict[bytes, tuple[int, int, tuple[int, ...], tuple[int, ...]]] = {}  # checked headers
_FIXED_NAMES = d.table_names("fixed")
_VARIABLE_NAMES = d.table_names("variable")
_NAN = math.nan
_VEL_LIST: list[float] = d.VELOCITY_LUT.tolist()


LAYOUT_NAMES = ("order", "padding", "spare", "gap")
NAMES = {
    d.FIXED_LEADER_ID: "fixed",
    d.VARIABLE_LEADER_ID: "variable",
    d.VELOCITY_ID: "velocity_mps",
    d.CORRELATION_ID: "correlation",
    d.ECHO_INTENSITY_ID: "echo_intensity",
    d.PERCENT_GOOD_ID: "percent_good",
    d.BOTTOM_TRACK_ID: "bottom_track",
}


def err(msg: str) -> DecodeError:
    return DecodeError(f"pd0: {msg}", fmt="pd0")


def fixed_leader(frame: bytes, start: int, end: int) -> FixedLeader:
    pl = d.prefix_layout("fixed", end - start)
    key = frame[start : start + pl.size]
    fl = _FIXED_CACHE.get(key)
    if fl is None:
        if pl.count < len(d.FIXED_LEADER) - 1:
            raise err(f"fixed leader of {end - start} bytes is too short")
        fl = fast_new(FixedLeader, pl.record_names, pl.scaled(pl.struct.unpack_from(frame, start)))
        if len(_FIXED_CACHE) >= 256:
            _FIXED_CACHE.clear()
        _FIXED_CACHE[key] = fl
    return fl


def variable_leader(frame: bytes, start: int, end: int) -> VariableLeader:
    pl = d.prefix_layout("variable", end - start)
    if pl.count < 26:  # through the error status word (46 bytes)
        raise err(f"variable leader of {end - start} bytes is too short")
    return fast_new(VariableLeader, pl.record_names, pl.scaled(pl.struct.unpack_from(frame, start)))


_BT_NAMES = (*(name for name, _, _ in d.BT_SCALARS), *d.BT_BYTE_QUADS, "range_m", "velocity_mps",
             "ref_velocity_mps", "range_msb")
# one C call picks the scalars and the per-beam byte quads out of the flat struct tuple
_BT_PICK = itemgetter(*(i for _, i, _ in d.BT_SCALARS), *d.BT_QUAD_SLICES.values())
_BT_SCALE = tuple((k, s) for k, (_, _, s) in enumerate(d.BT_SCALARS) if s is not None)


def bottom_track(frame: bytes, start: int, end: int) -> BottomTrack:
    if end - start < d.BT_BASE_SIZE:
        raise err(f"bottom track of {end - start} bytes is too short")
    raw = d.BT_BASE.struct.unpack_from(frame, start)
    has_msb = end - start >= d.BT_MSB_END
    cm: tuple[int, ...] | list[int] = raw[d.BT_RANGE]
    if has_msb:
        msb = d.BT_RANGE_MSB.unpack_from(frame, start + d.BT_BASE_SIZE)
        cm = [lo + (hi << 16) for lo, hi in zip(cm, msb, strict=True)]
    # the LUT list is indexed by the uint16 pattern; a negative int16 indexes from the end: the same
    per_beam = np.array([[c / 100.0 if c else _NAN for c in cm],
                         [_VEL_LIST[v] for v in raw[d.BT_VELOCITY]],
                         [_VEL_LIST[v] for v in raw[d.BT_REF_VELOCITY]]])
    per_beam.flags.writeable = False
    values = [*_BT_PICK(raw), *per_beam, has_msb]
    for k, scale in _BT_SCALE:
        values[k] *= scale
    return fast_new(BottomTrack, _BT_NAMES, values)


def ro(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def velocity_from_raw(raw: np.ndarray) -> np.ndarray:
    """int16 mm/s -> float m/s with NaN where bad (read-only)."""
    return ro(d.VELOCITY_LUT.take(np.asarray(raw, dtype=d.VELOCITY_DTYPE).view(d.VELOCITY_U16)))


def velocity_to_raw(v: np.ndarray) -> np.ndarray:
    """float m/s (NaN = bad) -> int16 mm/s; raises EncodeError outside the int16 range."""
    v = np.asarray(v, dtype=np.float64)
    mm = np.round(v * 1000.0)
    bad = np.isnan(mm)
    if np.any(np.abs(mm[~bad]) > 32767):
        raise EncodeError("pd0: velocity beyond +-32.767 m/s")
    return np.where(bad, d.BAD_VELOCITY, mm).astype("<i2")


def plan(frame: bytes, ndt: int) -> tuple[int, int, tuple[int, ...], tuple[int, ...]]:
    """(nbytes, spare, offsets, bounds) of a header, checked once per distinct header."""
    key = frame[2 : d.HEADER_SIZE + 2 * ndt]
    plan = _PLANS.get(key)
    if plan is None:
        _, _, nbytes, spare, _ = d.HEADER.unpack_from(frame)
        table_end = d.HEADER_SIZE + 2 * ndt
        if ndt == 0 or table_end > nbytes or len(frame) < table_end:
            raise err(f"bad number of data types {ndt}")
        offsets = OFFSETS[ndt].unpack_from(frame, d.HEADER_SIZE)
        bounds = (*offsets, nbytes)
        if offsets[0] < table_end or any(bounds[k + 1] - bounds[k] < 2 for k in range(ndt)):
            raise err(f"bad data-type offsets {offsets}")
        plan = (nbytes, spare, offsets, bounds)
        if len(_PLANS) >= 256:
            _PLANS.clear()
        _PLANS[key] = plan
    return plan


def pack_leader(table: str, names: tuple[str, ...], leader: Any, type_id: int) -> bytes:
    values = {"id": type_id}
    for name in names:
        v = getattr(leader, name)
        if v is None:
            break
        values[name] = v
    return d.layout_of_count(table, len(values)).layout.pack(values)


def pack_bt(bt: BottomTrack) -> bytes:
    values: dict[str, Any] = {"id": d.BOTTOM_TRACK_ID}
    for name, _, _ in d.BT_SCALARS:
        values[name] = getattr(bt, name)
    for q in d.BT_BYTE_QUADS:
        for k, v in enumerate(getattr(bt, q)):
            values[f"{q}_{k}"] = v
    cm = [0 if math.isnan(r) else round(r * 100.0) for r in bt.range_m.tolist()]
    limit = 1 << (24 if bt.range_msb else 16)
    if any(not 0 <= c < limit for c in cm):
        raise EncodeError(f"pd0: bottom-track range {bt.range_m} out of range")
    for k in range(4):
        values[f"range_lsb_{k}"] = cm[k] & 0xFFFF
    for prefix, arr in (("velocity", bt.velocity_mps), ("ref_velocity", bt.ref_velocity_mps)):
        for k, v in enumerate(velocity_to_raw(arr).tolist()):
            values[f"{prefix}_{k}"] = v
    out = d.BT_BASE.pack(values)
    return out + d.BT_RANGE_MSB.pack(*(c >> 16 for c in cm)) if bt.range_msb else out


def section(rec: Pd0Ensemble, tid: int) -> bytes | None:
    name = NAMES[tid]
    value = getattr(rec, name)
    if value is None:
        return None
    head = U16.pack(tid)
    if tid == d.FIXED_LEADER_ID:
        return pack_leader("fixed", _FIXED_NAMES, value, tid)
    if tid == d.VARIABLE_LEADER_ID:
        return pack_leader("variable", _VARIABLE_NAMES, value, tid)
    if tid == d.BOTTOM_TRACK_ID:
        return pack_bt(value)
    shape = (rec.fixed.n_cells, rec.fixed.n_beams)
    if value.shape != shape:
        raise EncodeError(f"pd0: {name} has shape {value.shape}, the fixed leader says {shape}")
    if tid == d.VELOCITY_ID:
        return head + velocity_to_raw(value).tobytes()
    if value.dtype != np.uint8 and (np.isnan(value).any() or value.min() < 0 or value.max() > 255):
        raise EncodeError(f"pd0: {name} must hold integers 0..255")
    return head + np.asarray(value, dtype=np.uint8).tobytes()
