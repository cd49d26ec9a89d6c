"""Bounded memo tables for array computations a stage repeats on the same data.

One identify job fits three methods x four data versions x seven pairings of one record:
the same input Gram blocks, state-matrix powers and lifted simulation matrices come back
again and again. :class:`ArrayMemo` remembers the last few results, keyed by the bytes of
the arrays they were computed from (:func:`array_key`), so a repeat costs a hash of those
bytes instead of the computation. A leaf module: numpy only.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import TypeVar

import numpy as np

__all__ = ["ArrayMemo", "array_key"]

T = TypeVar("T")


def array_key(*arrays: np.ndarray) -> tuple:
    """A hashable key equal for arrays of equal dtype, shape and bytes: their SHA-256.

    A digest, not the bytes themselves: a key of a whole record would otherwise hold a
    copy of it (16 MB at N = 1e6) for as long as the result is remembered.
    """
    return tuple((a.dtype.str, a.shape, hashlib.sha256(memoryview(a)).digest())
                 for a in (np.ascontiguousarray(v) for v in arrays))


def _freeze(value: object) -> None:
    # a remembered value is shared by every caller: its arrays must never be written
    for item in value if isinstance(value, tuple) else (value,):
        if isinstance(item, np.ndarray):
            item.setflags(write=False)


class ArrayMemo:
    """The last ``size`` results of a computation, least recently used dropped first.

    Parameters
    ----------
    size : int
        Number of results kept, > 0.

    Notes
    -----
    Values are returned as stored: arrays in them (or in a tuple of them) are made
    read-only, so a caller that writes into one gets an error instead of corrupting later
    results. Not thread-safe: each workflow job is one single-threaded process.
    """

    def __init__(self, size: int) -> None:
        if size < 1:
            raise ValueError(f"ArrayMemo size must be > 0, got {size}")
        self.size = size
        self._table: OrderedDict[Hashable, object] = OrderedDict()

    def __call__(self, key: Hashable, compute: Callable[[], T]) -> T:
        """``compute()``, or its remembered value for ``key``."""
        if key in self._table:
            self._table.move_to_end(key)
            return self._table[key]  # type: ignore[return-value]
        value = compute()
        _freeze(value)
        self._table[key] = value
        if len(self._table) > self.size:
            self._table.popitem(last=False)
        return value

    def __len__(self) -> int:
        return len(self._table)

    def clear(self) -> None:
        """Forget every result."""
        self._table.clear()
