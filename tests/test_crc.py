"""Checksums against their catalogue check values and the published vectors."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from auvlink.crc import crc16_modbus, crc32_mpeg2, crc32_mpeg2_reference, sum16


def test_check_values() -> None:
    assert crc32_mpeg2(b"123456789") == 0x0376E6E7
    assert crc32_mpeg2_reference(b"123456789") == 0x0376E6E7
    assert crc16_modbus(b"123456789") == 0x4B37
    assert crc16_modbus(bytes([0x02, 0x30])).to_bytes(2, "big") == bytes([0xC4, 0x00])  # high byte first


def test_kvh_vector() -> None:
    pkt = bytes.fromhex("FE81FF5537A96A6E38586C1FB75BF862BF803E78BB650D283B0A37AC773D0028")
    assert crc32_mpeg2(pkt) == 0x4BFA34D8


@given(st.binary(max_size=300))
def test_fast_crc_equals_reference(data: bytes) -> None:
    assert crc32_mpeg2(data) == crc32_mpeg2_reference(data)


@given(st.binary(max_size=2000))
def test_sum16(data: bytes) -> None:
    assert sum16(data) == sum(data) & 0xFFFF
