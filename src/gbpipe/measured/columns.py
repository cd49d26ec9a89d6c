"""Channels read block by block: what the streaming record reader asks of a format.

A :class:`Column` is one channel's samples behind random access: ``size`` and
``read(start, stop)``, which returns a fresh float64 array of samples ``start … stop-1``.
A :class:`StreamChannel` is the streamed twin of :class:`gbpipe.measured.channels.Channel`:
values (and explicit sample times, if any) as columns, plus the unit and the time base.

Implementations: :class:`ArrayColumn` (an array already in memory — the formats that are
not streamed), :class:`FileColumn` (raw float64 spilled to disk, e.g. a CSV column read
once in chunks), :class:`ScaledColumn` (a time channel in ``ms``, ``us``…); the TDMS
reader has its own, on :meth:`nptdms.TdmsChannel.read_data`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from gbpipe.errors import DataError
from gbpipe.measured.channels import Channel
from gbpipe.measured.spec import FileSpec

__all__ = ["Column", "ArrayColumn", "FileColumn", "ScaledColumn", "StreamChannel",
           "from_channel", "attach_stream", "blocks", "TIME_SCALE"]

#: seconds per unit of the mapping's ``time_unit``
TIME_SCALE = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "min": 60.0, "h": 3600.0}


def blocks(size: int, block: int) -> Iterator[tuple[int, int]]:
    """``(start, stop)`` of consecutive blocks of ``block`` samples covering ``size``."""
    for start in range(0, size, block):
        yield start, min(start + block, size)


class Column(Protocol):
    """Random access to one channel's samples."""

    size: int

    def read(self, start: int, stop: int) -> np.ndarray:
        """Samples ``start … stop-1`` as a new float64 array (the caller may change it)."""
        ...


class ArrayColumn:
    """A column over an array in memory."""

    def __init__(self, values: np.ndarray) -> None:
        self.values = np.asarray(values, dtype=float).ravel()
        self.size = self.values.size

    def read(self, start: int, stop: int) -> np.ndarray:
        return self.values[start:stop].copy()


class FileColumn:
    """A column of raw native float64 in a file (a spill of a text column)."""

    def __init__(self, path: Path, size: int) -> None:
        self.path, self.size = Path(path), int(size)

    def read(self, start: int, stop: int) -> np.ndarray:
        stop = min(stop, self.size)
        if stop <= start:
            return np.empty(0)
        # np.fromfile reads into a private buffer: unlike a memmap, pages read once do
        # not stay resident, so the peak memory is the block, not the file.
        return np.fromfile(self.path, dtype=np.float64, count=stop - start, offset=8 * start)


class ScaledColumn:
    """``factor`` times another column (time stamps in another time unit)."""

    def __init__(self, column: Column, factor: float) -> None:
        self.column, self.factor, self.size = column, float(factor), column.size

    def read(self, start: int, stop: int) -> np.ndarray:
        v = self.column.read(start, stop)
        if self.factor != 1.0:
            v *= self.factor
        return v


@dataclass
class StreamChannel:
    """Samples of one channel as a :class:`Column`, with their time base.

    Attributes as :class:`gbpipe.measured.channels.Channel`, with ``values`` and
    ``time`` columns instead of arrays; ``time`` is in seconds.
    """

    values: Column
    unit: str | None = None
    t0: float | None = None
    dt: float | None = None
    time: Column | None = None
    epoch: np.datetime64 | None = None


def from_channel(ch: Channel) -> StreamChannel:
    """The streamed view of a channel read into memory (formats that are not streamed)."""
    return StreamChannel(ArrayColumn(ch.values), ch.unit, ch.t0, ch.dt,
                         None if ch.time is None else ArrayColumn(ch.time), ch.epoch)


def attach_stream(values: Column, unit: str | None, fspec: FileSpec, source: str, name: str,
                  time_column: Column | None) -> StreamChannel:
    """The streamed twin of :func:`gbpipe.measured.formats.timebase_of.attach`: the time base
    the mapping gives a file whose channels carry none (``time:`` or ``sample_rate:``).

    Parameters
    ----------
    values : Column
        The channel's samples.
    unit : str or None
        The channel's unit as the file states it.
    fspec : FileSpec
        The file's mapping.
    source, name : str
        File and channel, for the error message.
    time_column : Column or None
        The ``time:`` channel in ``time_unit`` (``None`` when the mapping has none).
    """
    if fspec.time is None:
        if fspec.sample_rate is None:
            raise DataError(f"{source}: channel '{name}'", "the file carries no time base "
                            "for this channel: give the file a time: channel or a "
                            "sample_rate: [Hz]")
        return StreamChannel(values, unit, t0=0.0, dt=1.0 / fspec.sample_rate)
    scale = TIME_SCALE.get(fspec.time_unit)
    if scale is None:
        raise DataError(f"{source}: field 'time_unit'", f"unknown time unit "
                        f"{fspec.time_unit!r}; one of {', '.join(TIME_SCALE)}")
    if time_column.size != values.size:
        raise DataError(f"{source}: channel '{name}'", f"has {values.size} samples but time "
                        f"channel '{fspec.time}' has {time_column.size}")
    return StreamChannel(values, unit, time=ScaledColumn(time_column, scale))
