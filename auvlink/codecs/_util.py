"""Small helpers shared by the codec records: value equality and fast construction.

Records are frozen dataclasses; some hold numpy arrays or NaN for bad values, which the
dataclass ``__eq__`` cannot compare. :class:`ValueEq` compares field by field, arrays by value
and NaN equal to NaN, and skips fields declared with ``compare=False``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import fields
from typing import Any, TypeVar

import numpy as np

T = TypeVar("T")


def same(a: Any, b: Any) -> bool:
    """Value equality: arrays by shape, dtype and values; NaN equals NaN; tuples element-wise."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        if not (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)):
            return False
        if a.shape != b.shape or a.dtype != b.dtype:
            return False
        return bool(np.array_equal(a, b, equal_nan=a.dtype.kind == "f"))
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    return bool(a == b)


class ValueEq:
    """Mixin for ``@dataclass(frozen=True, eq=False)`` records: ``==`` through :func:`same`."""

    def __eq__(self, other: object) -> bool:
        if other.__class__ is not self.__class__:
            return NotImplemented
        return all(same(getattr(self, f.name), getattr(other, f.name))
                   for f in fields(self) if f.compare)  # type: ignore[arg-type]

    __hash__ = None  # type: ignore[assignment]


def fast_new(cls: type[T], names: Iterable[str], values: Iterable[Any]) -> T:
    """Construct a frozen (non-slots) dataclass without running ``__init__`` (decoder hot paths).

    Only for values that already have the right types; fields left out keep their class default.
    """
    obj = object.__new__(cls)
    obj.__dict__.update(zip(names, values, strict=False))
    return obj
