"""Declarative binary field tables compiled once into ``struct.Struct`` (after dolfyn's ``*_defs``).

A table is a sequence of :class:`Field` (name, struct format, scale, unit). ``Layout`` compiles it
into one ``struct.Struct`` and converts between raw integers and scaled SI values::

    LEADER = Layout("<", [Field("id", "H"), Field("speed_of_sound", "H", 1.0, "m/s")])
    values = LEADER.unpack_from(buf, offset)       # dict of scaled values
    LEADER.pack_into(buf, offset, values)          # inverse (rounds to the raw integer)
"""

from __future__ import annotations

import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Field:
    """One binary field: ``value_si = raw * scale``. ``fmt`` is a single struct code (``"4s"`` ok)."""

    name: str
    fmt: str
    scale: float = 1.0
    unit: str = ""

    @property
    def is_raw(self) -> bool:
        return self.scale == 1.0 or self.fmt.endswith("s")


class Layout:
    """A compiled field table."""

    def __init__(self, byte_order: str, fields: Sequence[Field]) -> None:
        self.fields = tuple(fields)
        self.struct = struct.Struct(byte_order + "".join(f.fmt for f in self.fields))
        self.size = self.struct.size
        self.names = tuple(f.name for f in self.fields)

    def unpack_from(self, buf: bytes | memoryview, offset: int = 0) -> dict[str, Any]:
        raw = self.struct.unpack_from(buf, offset)
        return {
            f.name: (v if f.is_raw else v * f.scale) for f, v in zip(self.fields, raw, strict=True)
        }

    def unpack_raw(self, buf: bytes | memoryview, offset: int = 0) -> dict[str, Any]:
        return dict(zip(self.names, self.struct.unpack_from(buf, offset), strict=True))

    def raw_values(self, values: Mapping[str, Any]) -> list[Any]:
        out: list[Any] = []
        for f in self.fields:
            v = values[f.name]
            if not f.is_raw:
                v = round(v / f.scale)
            out.append(v)
        return out

    def pack(self, values: Mapping[str, Any]) -> bytes:
        return self.struct.pack(*self.raw_values(values))

    def pack_into(self, buf: bytearray, offset: int, values: Mapping[str, Any]) -> None:
        self.struct.pack_into(buf, offset, *self.raw_values(values))
