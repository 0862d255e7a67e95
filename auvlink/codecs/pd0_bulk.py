"""Vectorized PD0 reading for whole files and replays (numpy, no per-field Python work).

Spec: Teledyne RD Instruments, "WorkHorse Commands and Output Data Format" (P/N 957-6156-00),
chapter "PD0 Output Format": header 0x7F7F, fixed leader 0x0000, variable leader 0x0080,
velocity 0x0100, bottom track 0x0600; checksum = sum of bytes [0, nbytes) mod 65536.

How: every ``7F 7F`` pair is a candidate header; the 16-bit sums come from one prefix sum over
the file, so each candidate's checksum costs O(1). Valid ensembles are grouped by layout (length
and data-type offsets); each group is one ``(n, length)`` uint8 array, and every field is a
strided column view of it. The per-frame codec in :mod:`auvlink.codecs.pd0` stays the reference;
a test checks the two agree on every capture.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

BAD_VELOCITY = -32768
COORDINATE_SYSTEMS = ("beam", "instrument", "ship", "earth")


@dataclass(frozen=True)
class Pd0Batch:
    """Arrays over the ensembles of a file, in file order. SI units; NaN where bad."""

    offsets: NDArray[np.int64]  # byte offset of each ensemble in the file
    ensemble_number: NDArray[np.int64]
    time: NDArray[np.float64]  # s since the UNIX epoch (UTC), from the ensemble RTC
    heading: NDArray[np.float64]  # rad
    pitch: NDArray[np.float64]  # rad
    roll: NDArray[np.float64]  # rad
    temperature_c: NDArray[np.float64]
    coordinate_system: NDArray[np.str_]
    bt_velocity: NDArray[np.float64]  # (n, 4) m/s as stored (PD0 sign convention), NaN when bad
    bt_range: NDArray[np.float64]  # (n, 4) m, NaN when no bottom

    def __len__(self) -> int:
        return int(self.offsets.size)


def find_ensembles(data: bytes) -> list[tuple[int, int]]:
    """(offset, nbytes) of every ensemble whose checksum verifies, skipping anything else."""
    buf = np.frombuffer(data, dtype=np.uint8)
    if buf.size < 8:
        return []
    prefix = np.zeros(buf.size + 1, dtype=np.int64)
    np.cumsum(buf, out=prefix[1:])
    cand = np.flatnonzero((buf[:-1] == 0x7F) & (buf[1:] == 0x7F))
    cand = cand[cand + 6 <= buf.size]
    nbytes = buf[cand + 2].astype(np.int64) | (buf[cand + 3].astype(np.int64) << 8)
    end = cand + nbytes + 2
    ok = (nbytes >= 8) & (end <= buf.size)
    cand, nbytes, end = cand[ok], nbytes[ok], end[ok]
    sums = (prefix[cand + nbytes] - prefix[cand]) & 0xFFFF
    stored = buf[end - 2].astype(np.int64) | (buf[end - 1].astype(np.int64) << 8)
    good = sums == stored
    cand, nbytes = cand[good].tolist(), nbytes[good].tolist()
    out: list[tuple[int, int]] = []
    pos = 0
    for start, n in zip(cand, nbytes, strict=True):
        if start >= pos:
            out.append((start, n))
            pos = start + n + 2
    return out


def _u16(block: NDArray[np.uint8], col: int) -> NDArray[np.int64]:
    return block[:, col].astype(np.int64) | (block[:, col + 1].astype(np.int64) << 8)


def _i16(block: NDArray[np.uint8], col: int) -> NDArray[np.int64]:
    v = _u16(block, col)
    return np.where(v >= 0x8000, v - 0x10000, v)


def _rtc_epoch(year2: NDArray[np.int64], mon: NDArray[np.int64], day: NDArray[np.int64],
               hms: NDArray[np.int64], hund: NDArray[np.int64]) -> NDArray[np.float64]:
    year = np.where(year2 < 80, 2000 + year2, 1900 + year2)
    dates = (year - 1970).astype("datetime64[Y]").astype("datetime64[M]") + (np.clip(mon, 1, 12) - 1)
    days = dates.astype("datetime64[D]") + (np.clip(day, 1, 31) - 1)
    return days.astype("datetime64[s]").astype(np.float64) + hms + hund * 0.01


def decode_file_bulk(data: bytes) -> Pd0Batch:
    """Decode every valid ensemble of a PD0 byte string into arrays."""
    found = find_ensembles(data)
    buf = np.frombuffer(data, dtype=np.uint8)
    groups: dict[bytes, list[int]] = {}
    for i, (start, _n) in enumerate(found):
        ntypes = int(buf[start + 5])
        sig = bytes(buf[start + 2 : start + 6 + 2 * ntypes])
        groups.setdefault(sig, []).append(i)
    m = len(found)
    res = {k: np.full(m, np.nan) for k in ("time", "heading", "pitch", "roll", "temperature_c")}
    ens = np.zeros(m, dtype=np.int64)
    coord = np.empty(m, dtype="<U10")
    btv = np.full((m, 4), np.nan)
    btr = np.full((m, 4), np.nan)
    offsets = np.array([s for s, _ in found], dtype=np.int64)
    for sig, idx_list in groups.items():
        idx = np.asarray(idx_list)
        length = found[idx_list[0]][1] + 2
        rows = offsets[idx][:, None] + np.arange(length)[None, :]
        block = buf[rows]
        ntypes = sig[3]
        type_offsets = [int.from_bytes(sig[4 + 2 * k : 6 + 2 * k], "little") for k in range(ntypes)]
        for off in type_offsets:
            if off + 2 > length:
                continue
            tid = int(block[0, off]) | (int(block[0, off + 1]) << 8)
            if tid == 0x0000:
                ex = block[:, off + 25]
                coord[idx] = np.asarray(COORDINATE_SYSTEMS)[(ex >> 3) & 0x3]
            elif tid == 0x0080:
                b = block
                ens[idx] = _u16(b, off + 2) + (b[:, off + 11].astype(np.int64) << 16)
                hms = b[:, off + 7].astype(np.int64) * 3600 + b[:, off + 8] * 60 + b[:, off + 9]
                y, mo, d = (b[:, off + k].astype(np.int64) for k in (4, 5, 6))
                res["time"][idx] = _rtc_epoch(y, mo, d, hms, b[:, off + 10].astype(np.int64))
                res["heading"][idx] = np.deg2rad(_u16(b, off + 18) * 0.01)
                res["pitch"][idx] = np.deg2rad(_i16(b, off + 20) * 0.01)
                res["roll"][idx] = np.deg2rad(_i16(b, off + 22) * 0.01)
                res["temperature_c"][idx] = _i16(b, off + 26) * 0.01
            elif tid == 0x0600 and off + 32 <= length:
                vel = np.stack([_i16(block, off + 24 + 2 * k) for k in range(4)], axis=1)
                rng = np.stack([_u16(block, off + 16 + 2 * k) for k in range(4)], axis=1)
                if off + 81 <= length:
                    msb = block[:, off + 77 : off + 81].astype(np.int64)
                    rng = rng + (msb << 16)
                btv[idx] = np.where(vel == BAD_VELOCITY, np.nan, vel * 1e-3)
                btr[idx] = np.where(rng == 0, np.nan, rng * 1e-2)
    return Pd0Batch(offsets=offsets, ensemble_number=ens, time=res["time"], heading=res["heading"],
                    pitch=res["pitch"], roll=res["roll"], temperature_c=res["temperature_c"],
                    coordinate_system=coord, bt_velocity=btv, bt_range=btr)


def utc(t: float) -> dt.datetime:
    """Epoch seconds -> aware UTC datetime."""
    return dt.datetime.fromtimestamp(t, dt.UTC)
