"""Teledyne RDI PD0 codec: one binary ensemble <-> :class:`Pd0Ensemble` (SI units).

Spec: Teledyne RD Instruments, "WorkHorse Commands and Output Data Format" (P/N 957-6156-00),
chapter "PD0 Output Format". An ensemble is a header (0x7F7F, nbytes, spare, number of data
types, a table of u16 offsets), then the data types at those offsets, then a u16 checksum: the
sum of bytes [0, nbytes) modulo 65536, at offset nbytes. Field tables: :mod:`.pd0_defs`;
records: :mod:`.pd0_records`; building new ensembles (the simulator): :mod:`.pd0_build`.

``decode`` is exact: ``encode(decode(frame)) == frame`` for every valid ensemble, including
unknown data types (kept raw), padding and 58/59-byte fixed or 46/60/65-byte variable leaders.
"""

from __future__ import annotations

import math
import struct
from typing import Any

import numpy as np

from auvlink.codecs import pd0_defs as d
from auvlink.codecs._util import fast_new
from auvlink.codecs.pd0_lib import (
    LAYOUT_NAMES,
    NAMES,
    OFFSETS,
    U16,
    bottom_track,
    err,
    fixed_leader,
    plan,
    ro,
    section,
    variable_leader,
)
from auvlink.codecs.pd0_records import BottomTrack, FixedLeader, Pd0Ensemble, Pd0Layout, VariableLeader
from auvlink.errors import ChecksumError, EncodeError
from auvlink.formats import WireFormat
from auvlink.framing.pd0 import Pd0Framer, sum16

__all__ = ["WIRE_FORMAT", "BottomTrack", "FixedLeader", "Pd0Ensemble", "Pd0Layout", "VariableLeader",
           "decode", "encode", "sensor_time", "to_json"]


def decode(frame: bytes, *, verify: bool = True) -> Pd0Ensemble:
    """One PD0 ensemble (``7F 7F`` ... checksum) -> :class:`Pd0Ensemble`."""
    if not isinstance(frame, bytes):
        frame = bytes(frame)
    n = len(frame)
    if n < d.HEADER_SIZE + 2 or frame[0] != 0x7F or frame[1] != 0x7F:
        raise err("not a PD0 ensemble (no 7F 7F header)")
    ndt = frame[5]
    nbytes, spare, offsets, bounds = plan(frame, ndt)
    if n != nbytes + 2:
        raise err(f"frame is {n} bytes but its header says {nbytes} + 2")
    if verify:
        expected = frame[nbytes] | frame[nbytes + 1] << 8
        actual = sum16(frame, 0, nbytes)
        if expected != actual:
            raise ChecksumError("pd0", expected, actual)
    ids = [frame[o] | frame[o + 1] << 8 for o in offsets]
    if d.FIXED_LEADER_ID not in ids or d.VARIABLE_LEADER_ID not in ids:
        raise err("ensemble without fixed or variable leader")
    k0 = ids.index(d.FIXED_LEADER_ID)
    fixed = fixed_leader(frame, offsets[k0], bounds[k0 + 1])
    cells, beams = fixed.n_cells, fixed.n_beams
    count = cells * beams
    kw: dict[str, Any] = {}
    padding: list[bytes] = []
    other: list[tuple[int, bytes]] = []
    for k, tid in enumerate(ids):
        start, end = offsets[k], bounds[k + 1]
        name = NAMES.get(tid)
        if name is None or name in kw:
            other.append((tid, frame[start:end]))
            padding.append(b"")
            continue
        if tid == d.FIXED_LEADER_ID:
            kw[name] = fixed
            stop = start + d.prefix_layout("fixed", end - start).size
        elif tid == d.VARIABLE_LEADER_ID:
            kw[name] = variable_leader(frame, start, end)
            stop = start + d.prefix_layout("variable", end - start).size
        elif tid == d.BOTTOM_TRACK_ID:
            kw[name] = bottom_track(frame, start, end)
            stop = start + (d.BT_MSB_END if end - start >= d.BT_MSB_END else d.BT_BASE_SIZE)
        else:
            stop = start + 2 + (2 if tid == d.VELOCITY_ID else 1) * count
            if stop > end:
                raise err(f"data type 0x{tid:04X} holds {end - start} bytes, needs {stop - start}")
            if tid == d.VELOCITY_ID:
                u16 = np.frombuffer(frame, d.VELOCITY_U16, count, start + 2)
                kw[name] = ro(d.VELOCITY_LUT.take(u16).reshape(cells, beams))
            else:
                kw[name] = np.frombuffer(frame, d.BYTE_DTYPE, count, start + 2).reshape(cells, beams)
        padding.append(frame[stop:end] if stop < end else b"")
    layout = fast_new(Pd0Layout, LAYOUT_NAMES,
                      (tuple(ids), tuple(padding), spare, frame[d.HEADER_SIZE + 2 * ndt : offsets[0]]))
    kw["other"] = tuple(other)
    kw["layout"] = layout
    return fast_new(Pd0Ensemble, kw.keys(), kw.values())


def encode(rec: Pd0Ensemble) -> bytes:
    """:class:`Pd0Ensemble` -> PD0 bytes, checksum included (the layout of ``rec.layout``)."""
    lay = rec.layout
    others = list(rec.other)
    done: set[int] = set()
    sections: list[bytes] = []
    try:
        for k, tid in enumerate(lay.order):
            pad = lay.padding[k] if k < len(lay.padding) else b""
            if tid in NAMES and tid not in done:
                body = section(rec, tid)
                done.add(tid)
                if body is not None:
                    sections.append(body + pad)
                continue
            j = next((i for i, (oid, _) in enumerate(others) if oid == tid), None)
            if j is not None:
                sections.append(others.pop(j)[1])
        for tid in NAMES:
            if tid not in done and (body := section(rec, tid)) is not None:
                sections.append(body)
        sections.extend(raw for _, raw in others)
        ndt = len(sections)
        pos = d.HEADER_SIZE + 2 * ndt + len(lay.gap)
        offsets = []
        for s in sections:
            offsets.append(pos)
            pos += len(s)
        if pos > 0xFFFF or ndt > 255:
            raise EncodeError(f"pd0: ensemble of {pos} bytes / {ndt} data types does not fit PD0")
        out = d.HEADER.pack(0x7F, 0x7F, pos, lay.spare, ndt) + OFFSETS[ndt].pack(*offsets) + lay.gap
        out += b"".join(sections)
    except struct.error as exc:
        raise EncodeError(f"pd0: a field is out of range: {exc}") from exc
    return out + U16.pack(sum16(out, 0, len(out)))


def _nullable(a: np.ndarray, ndigits: int) -> list[Any]:
    return [None if math.isnan(x) else round(x, ndigits) for x in a.tolist()]


def to_json(rec: Pd0Ensemble) -> dict[str, Any]:
    """JSON-ready summary in SI units (angles in degrees, null where bad)."""
    t = rec.time
    f, v = rec.fixed, rec.variable
    out: dict[str, Any] = {
        "ensemble_number": rec.ensemble_number,
        "time": None if t is None else t.isoformat(timespec="milliseconds").replace("+00:00", "Z"),
        "coordinate_system": rec.coordinate_system,
        "heading_deg": round(math.degrees(v.heading_rad), 2),
        "pitch_deg": round(math.degrees(v.pitch_rad), 2),
        "roll_deg": round(math.degrees(v.roll_rad), 2),
        "temperature_c": round(v.temperature_c, 2),
        "depth_m": round(v.depth_m, 1),
        "salinity_ppt": v.salinity_ppt,
        "speed_of_sound_mps": v.speed_of_sound_mps,
        "pressure_pa": v.pressure_pa,
        "serial_number": f.serial_number,
        "firmware": f.firmware,
        "n_beams": f.n_beams,
        "n_cells": f.n_cells,
        "cell_size_m": round(f.cell_size_m, 2),
        "bin1_distance_m": round(f.bin1_distance_m, 2),
        "bt_velocity_mps": _nullable(rec.bt_velocity_mps, 3),
        "bt_range_m": _nullable(rec.bt_range_m, 2),
        "velocity_mps": None if rec.velocity_mps is None else [_nullable(row, 3) for row in rec.velocity_mps],
        "other_data_types": [f"0x{tid:04X}" for tid, _ in rec.other],
    }
    return out


def sensor_time(rec: Pd0Ensemble) -> float | None:
    """Ensemble time from its real-time clock, in s since the UNIX epoch (UTC)."""
    return rec.sensor_time


WIRE_FORMAT = WireFormat(
    name="pd0",
    encoding="rdi.pd0",
    description="Teledyne RDI PD0 binary ensembles (DVL / ADCP)",
    decode=decode,
    encode=encode,
    framer=Pd0Framer,
    sensor_time=sensor_time,
    to_json=to_json,
)
