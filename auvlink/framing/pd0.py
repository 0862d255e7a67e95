"""Framer for Teledyne RDI PD0 ensembles (WorkHorse "Commands and Output Data Format", PD0 chapter).

An ensemble starts ``7F 7F``, then nbytes (u16 LE, the checksum's 2 bytes not counted), a spare
byte, the number of data types and their u16 offsets; it ends with the u16 sum of bytes
[0, nbytes). The framer finds a header with ``bytes.find``, rejects implausible ones at once
(nbytes < 6 or above ``max_nbytes``, offsets table not increasing inside the ensemble), waits for
nbytes + 2 bytes and checks the sum. Sums of long candidates come from a running prefix sum of the
buffer (kept across feeds), so a stream of plausible headers that each claim 64 KiB costs O(1) per
candidate, not O(nbytes): the framer stays linear in its input whatever the headers claim. A failed
sum counts in ``stats.bad_checksums`` and the search resumes one byte after that header, so an
ensemble overlapping a damaged one is kept.

WorkHorse waves records (``7F 79``, same length and checksum rule) interleaved with ensembles
are verified and skipped whole: their bytes count as dropped and :attr:`Pd0Framer.waves_records`
counts them. At end of stream, a header whose ensemble is incomplete is truncated unless a whole
ensemble follows it (then it was a false header and is dropped).
"""

from __future__ import annotations

import re
from zlib import adler32

import numpy as np

from auvlink.framing.base import Framer

_PD0 = 0x7F
_WAVES = 0x79
_CHUNK = 256  # 255 * 256 + 1 < 65521: Adler-32's A of a chunk is exactly 1 + its byte sum
_RUN = 10  # a header starting with ten 0x7F bytes is impossible (its first offset lies past nbytes)
_RUN_TAIL = b"\x7f" * (_RUN - 1)
_NOT_7F = re.compile(b"[^\x7f]")
_NUMPY_FROM = 2048  # above this many bytes one numpy reduction beats the chunked Adler-32


def sum16(buf: bytes | bytearray, start: int, n: int) -> int:
    """RDI checksum: sum of ``buf[start:start + n]`` modulo 65536 (in C: Adler-32 sums or numpy)."""
    if n > _NUMPY_FROM:
        view = np.frombuffer(buf, np.uint8, n, start)
        total = int(np.add.reduce(view, dtype=np.uint32))
        del view  # release the buffer export so a bytearray can be resized again
        return total & 0xFFFF
    total = 0
    stop = start + n
    for k in range(start, stop, _CHUNK):
        total += (adler32(buf[k : min(k + _CHUNK, stop)]) & 0xFFFF) - 1
    return total & 0xFFFF


class Pd0Framer(Framer):
    """Cuts a byte stream into whole, checksum-verified PD0 ensembles (``7F 7F`` ... sum)."""

    format_name = "pd0"

    def __init__(self, max_nbytes: int = 0xFFFF) -> None:
        super().__init__()
        self.max_nbytes = max_nbytes
        #: 0x7F79 waves records skipped whole (their bytes are also in ``stats.dropped_bytes``)
        self.waves_records = 0
        self._good_headers: set[bytes] = set()  # headers already found plausible (they repeat)
        # running prefix sum (mod 65536) of the buffer: _cs[_lo + k] = sum of buf[:k] (+ a constant)
        self._cs = np.zeros(0, np.uint16)
        self._lo = self._hi = 0

    def reset(self) -> None:
        super().reset()
        self._lo = self._hi = 0

    def flush(self) -> list[bytes]:
        frames = super().flush()
        self._lo = self._hi = 0  # the buffer was cleared
        return frames

    def _sum(self, buf: bytearray, i: int, n: int) -> int:
        """RDI checksum of ``buf[i:i + n]``; long spans from the running prefix sum (O(1) each)."""
        if n <= _NUMPY_FROM:
            return sum16(buf, i, n)
        covered = self._hi - self._lo - 1  # bytes of buf the prefix covers (-1: none yet)
        if covered < 0:
            self._lo = self._hi = 0
            covered = 0
            need = len(buf) + 1
        else:
            need = len(buf) - covered
        if need > 0:
            live = self._hi - self._lo
            if self._hi + need > len(self._cs):  # compact (and grow): amortized O(1) per byte
                cs = np.zeros(max(len(self._cs), 2 * (live + need)), np.uint16)
                cs[:live] = self._cs[self._lo : self._hi]
                self._cs, self._lo, self._hi = cs, 0, live
            if self._hi == self._lo:
                self._cs[self._hi] = 0
                self._hi += 1
                need -= 1
            view = np.frombuffer(buf, np.uint8, need, covered)
            run = np.cumsum(view, dtype=np.uint16)
            del view  # release the buffer export so the bytearray can be resized again
            run += self._cs[self._hi - 1]
            self._cs[self._hi : self._hi + need] = run
            self._hi += need
        a = self._lo + i
        return (int(self._cs[a + n]) - int(self._cs[a])) & 0xFFFF

    @property
    def max_frame(self) -> int:  # type: ignore[override]
        return self.max_nbytes + 2

    def _plausible(self, buf: bytes | bytearray, i: int, nbytes: int, n: int) -> bool | None:
        """Header sanity at ``i``: True / False, or None when more bytes are needed to tell."""
        if i + 6 > n:
            return None
        ndt = buf[i + 5]
        table_end = 6 + 2 * ndt
        if ndt == 0 or table_end + 2 * ndt > nbytes:
            return False
        if i + table_end > n:
            return None
        prev = table_end - 2
        for k in range(min(ndt, 2)):  # the first offsets alone reject most false headers (0x7F7F...)
            o = i + 6 + 2 * k
            off = buf[o] | buf[o + 1] << 8
            if off < prev + 2 or off + 2 > nbytes:
                return False
            prev = off
        key = bytes(buf[i + 2 : i + table_end])
        if key in self._good_headers:
            return True
        prev = table_end - 2
        for k in range(ndt):
            o = i + 6 + 2 * k
            off = buf[o] | buf[o + 1] << 8
            if off < prev + 2 or off + 2 > nbytes:
                return False
            prev = off
        if len(self._good_headers) >= 64:
            self._good_headers.clear()
        self._good_headers.add(key)
        return True

    def _whole(self, data: bytes | bytearray | memoryview) -> bytes | None:
        raw = data if isinstance(data, bytes) else bytes(data)
        n = len(raw)
        if n < 8 or raw[0] != _PD0 or raw[1] != _PD0:
            return None
        nbytes = raw[2] | raw[3] << 8
        if nbytes + 2 != n or nbytes < 6 or nbytes > self.max_nbytes or not self._plausible(raw, 0, nbytes, n):
            return None
        return raw if sum16(raw, 0, nbytes) == raw[n - 2] | raw[n - 1] << 8 else None

    def _extract(self, buf: bytearray, final: bool = False) -> list[bytes]:
        frames: list[bytes] = []
        n = len(buf)
        pos = 0  # bytes before pos are consumed (frames taken, garbage counted)
        search = 0
        pending = -1  # final: start of an incomplete candidate that may be a truncated ensemble
        wait = -1  # not final: start of a candidate that needs more bytes
        stats = self.stats
        while True:
            i = buf.find(b"\x7f", search)
            if i < 0:
                break
            search = i + 1
            if buf[i + 1 : i + _RUN] == _RUN_TAIL:  # ten 0x7F: nbytes 0x7F7F < first offset + 2, no header
                m = _NOT_7F.search(buf, i + _RUN)
                search = (m.start() if m else n) - _RUN + 1  # every start in the run is one of these
                continue
            if i + 1 < n and buf[i + 1] != _PD0 and buf[i + 1] != _WAVES:
                continue
            end = -1  # unknown until the header is whole
            if i + 4 <= n:
                nbytes = buf[i + 2] | buf[i + 3] << 8
                if nbytes < 6 or nbytes > self.max_nbytes:
                    continue
                ok = self._plausible(buf, i, nbytes, n) if buf[i + 1] == _PD0 else True
                if ok is False:
                    continue
                if ok:
                    end = i + nbytes + 2
            if end < 0 or end > n:  # incomplete: wait for bytes, or at the end, maybe truncated
                if not final:
                    wait = i
                    break
                if pending < 0:
                    pending = i
                continue
            if self._sum(buf, i, nbytes) != buf[end - 2] | buf[end - 1] << 8:
                if pending < 0:
                    stats.bad_checksums += 1
                continue
            stats.dropped_bytes += i - pos
            pending = -1
            if buf[i + 1] == _PD0:
                frames.append(bytes(buf[i:end]))
            else:
                self.waves_records += 1
                stats.dropped_bytes += end - i
            pos = search = end
        # keep the earliest candidate still open: it waits for bytes, or flush counts it truncated
        keep = pending if pending >= 0 else (wait if wait >= 0 else n)
        stats.dropped_bytes += keep - pos
        del buf[:keep]
        self._lo += keep
        if self._lo >= self._hi:  # the prefix no longer covers the buffer's front: start afresh
            self._lo = self._hi = 0
        return frames
