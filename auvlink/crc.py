"""Checksums used by the wire formats (table driven, tables built once at import).

- CRC-32/MPEG-2: poly 0x04C11DB7, init 0xFFFFFFFF, no reflection, no final xor (KVH DSP-1760).
- CRC-16/MODBUS: poly 0xA001 reflected, init 0xFFFF (Keller bus; sent high byte first).
- RDI PD0: 16-bit sum of bytes.
"""

from __future__ import annotations

import zlib

import numpy as np


def _crc32_mpeg2_table() -> list[int]:
    table = []
    for byte in range(256):
        crc = byte << 24
        for _ in range(8):
            crc = ((crc << 1) ^ 0x04C11DB7) if crc & 0x80000000 else (crc << 1)
        table.append(crc & 0xFFFFFFFF)
    return table


def _crc16_modbus_table() -> list[int]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
        table.append(crc)
    return table


_CRC32_MPEG2 = _crc32_mpeg2_table()
_CRC16_MODBUS = _crc16_modbus_table()


#: bit-reversal of every byte value: turns the reflected zlib CRC-32 into the unreflected MPEG-2 one
_REVERSE_BITS = bytes(int(f"{i:08b}"[::-1], 2) for i in range(256))


def crc32_mpeg2(data: bytes) -> int:
    """CRC-32/MPEG-2 of ``data`` (check value of b"123456789" is 0x0376E6E7).

    Same polynomial as zlib's CRC-32 without reflection and final xor: reversing the bits of every
    input byte and of the result maps one onto the other, so C code does the work.
    """
    reflected = zlib.crc32(bytes(data).translate(_REVERSE_BITS)) ^ 0xFFFFFFFF
    return int.from_bytes(reflected.to_bytes(4, "little").translate(_REVERSE_BITS), "big")


def crc32_mpeg2_reference(data: bytes) -> int:
    """Table-driven CRC-32/MPEG-2 (the reference :func:`crc32_mpeg2` is tested against)."""
    crc = 0xFFFFFFFF
    table = _CRC32_MPEG2
    for b in data:
        crc = ((crc << 8) & 0xFFFFFFFF) ^ table[((crc >> 24) ^ b) & 0xFF]
    return crc


def crc16_modbus(data: bytes) -> int:
    """CRC-16/MODBUS of ``data`` (check value of b"123456789" is 0x4B37)."""
    crc = 0xFFFF
    table = _CRC16_MODBUS
    for b in data:
        crc = (crc >> 8) ^ table[(crc ^ b) & 0xFF]
    return crc


def sum16(data: bytes) -> int:
    """RDI PD0 checksum: the sum of all bytes modulo 65536."""
    return int(np.frombuffer(data, dtype=np.uint8).sum(dtype=np.uint64)) & 0xFFFF
