"""NI TDMS files through npTDMS, streamed.

Addressing: ``group/channel``. Time base, in order: the mapping's ``time:`` channel
(``group/channel``), else the channel's waveform properties ``wf_increment`` [s] with
``wf_start_offset`` [s] and ``wf_start_time`` (absolute), else the file's ``sample_rate:``.
Unit: the ``unit_string`` property.

The file is opened with :meth:`nptdms.TdmsFile.open`, which reads only the metadata; a
channel's data is then read in blocks of :data:`BLOCK` values and converted to float64
block by block, so memory stays at one float64 copy of the channels asked for.
:meth:`TdmsSource.stream` reads nothing: it returns the channel as a :class:`TdmsColumn`
that the streaming reader (:mod:`gbpipe.measured.stream`) reads block by block.

Interleaved columns without metadata: a file whose only channel (say
``Measurements/Time``) holds ``n`` columns row by row, the mapping naming the columns
(``interleaved: [Time, MotorTorqueSet, ...]``): column ``k`` is ``values[k::n]``; its
time base is a column (``time:``) or ``sample_rate:`` [rows/s], its unit the mapping's.

``NI_ArrayColumn`` layout: some NI programs store a 2-D array as channels carrying the
property ``NI_ArrayColumn = k``, with every column interleaved (row-major) in the first
channel (column 0) and the other channels empty. Column ``k`` is then
``first[k::n_columns]``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from nptdms import TdmsFile

from gbpipe.errors import DataError
from gbpipe.measured.channels import Channel, find
from gbpipe.measured.columns import StreamChannel, attach_stream
from gbpipe.measured.formats.timebase_of import attach
from gbpipe.measured.spec import FileSpec

__all__ = ["TdmsSource", "TdmsColumn", "BLOCK"]

#: values read per block (8 MB of float64)
BLOCK = 1 << 20


class TdmsSource:
    """Channels of one TDMS file (see the module docstring)."""

    def __init__(self, path: Path, fspec: FileSpec) -> None:
        self.path, self.fspec = path, fspec
        try:
            self._file = TdmsFile.open(path)
        except Exception as exc:  # npTDMS raises bare ValueError/EOFError on bad files
            raise DataError(str(path), f"not a readable TDMS file (truncated or corrupt?): "
                            f"{exc}") from exc
        status = self._file.file_status
        if status.incomplete_final_segment:
            self._file.close()
            detail = "; ".join(f"{k}: {v.read_length} of {v.expected_length} values"
                               for k, v in (status.channel_statuses or {}).items())
            raise DataError(str(path), f"truncated: the last segment of the file is "
                            f"incomplete ({detail or 'length mismatch'}); copy the "
                            f"complete file, or cut it at the last complete segment")
        self._channels = {f"{g.name}/{c.name}": c
                          for g in self._file.groups() for c in g.channels()}
        #: column name -> index, for a file whose columns are interleaved in one channel
        self._index: dict[str, int] = {}
        if fspec.interleaved is not None:
            carrier = self._carrier()
            self._index = {c: k for k, c in enumerate(fspec.interleaved)}
            self._channels = dict.fromkeys(fspec.interleaved, carrier)

    def _carrier(self):
        """The one non-empty channel that holds the ``interleaved:`` columns."""
        full = [n for n, c in self._channels.items() if len(c)]
        if len(full) != 1:
            self._file.close()
            raise DataError(f"{self.path}: field 'interleaved'", f"{len(full)} channels hold "
                            f"data ({', '.join(full) or 'none'}); interleaved: reads files "
                            f"whose columns all sit in one channel: map the channels by "
                            f"name instead")
        return self._channels[full[0]]

    def names(self) -> list[str]:
        return list(self._channels)

    def prefetch(self, names: list[str]) -> None:
        """Nothing to do: TDMS channels are read independently."""

    def close(self) -> None:
        self._file.close()

    def _array_column(self, ch) -> tuple[object, int, int] | None:
        """(column-0 channel, column index, column count) of an ``NI_ArrayColumn`` channel
        whose data sit interleaved in column 0, else ``None``."""
        if "NI_ArrayColumn" not in ch.properties:
            return None
        group = ch.group_name
        cols = {int(c.properties["NI_ArrayColumn"]): c
                for c in self._file[group].channels() if "NI_ArrayColumn" in c.properties}
        first = cols.get(0)
        if first is None or any(len(c) for k, c in cols.items() if k != 0):
            return None  # an ordinary file where each column channel holds its own data
        return first, int(ch.properties["NI_ArrayColumn"]), len(cols)

    def _column(self, name: str, ch) -> TdmsColumn:
        if self._index:
            return TdmsColumn(ch, self._index[name], len(self._index),
                              f"{self.path}: channel '{name}'")
        layout = self._array_column(ch)
        src, k, ncol = (ch, 0, 1) if layout is None else layout
        return TdmsColumn(src, k, ncol, f"{self.path}: channel '{name}'")

    def _data(self, name: str, ch) -> np.ndarray:
        column = self._column(name, ch)
        return column.read(0, column.size)

    def read(self, name: str) -> Channel:
        name = find(name, self.names(), str(self.path))
        ch = self._channels[name]
        base = self._waveform(name, ch)
        if base is not None:
            return Channel(self._data(name, ch), self._unit(ch), t0=base[0], dt=base[1],
                           epoch=base[2])

        def read_time(tname: str) -> np.ndarray:
            tname = find(tname, self.names(), f"{self.path} (field 'time')")
            return self._data(tname, self._channels[tname])

        return attach(self._data(name, ch), self._unit(ch), self.fspec, str(self.path), name,
                      read_time)

    def _unit(self, ch) -> str | None:
        """The channel's ``unit_string``; none for interleaved columns (the carrier's unit
        is not theirs)."""
        return None if self._index else ch.properties.get("unit_string") or None

    def stream(self, name: str) -> StreamChannel:
        """The channel ``name`` for block-wise reading (nothing is read yet)."""
        name = find(name, self.names(), str(self.path))
        ch = self._channels[name]
        values = self._column(name, ch)
        unit = self._unit(ch)
        base = self._waveform(name, ch)
        if base is not None:
            return StreamChannel(values, unit, t0=base[0], dt=base[1], epoch=base[2])
        time = None
        if self.fspec.time is not None:
            tname = find(self.fspec.time, self.names(), f"{self.path} (field 'time')")
            time = self._column(tname, self._channels[tname])
        return attach_stream(values, unit, self.fspec, str(self.path), name, time)

    def _waveform(self, name: str, ch) -> tuple[float, float, np.datetime64 | None] | None:
        """(t0 [s], dt [s], absolute epoch) from the waveform properties, when the mapping
        gives no ``time:`` channel and the channel has ``wf_increment``; else ``None``."""
        props = ch.properties
        # interleaved: the carrier's increment is per value, not per row of columns
        if self.fspec.time is not None or "wf_increment" not in props or self._index:
            return None
        dt = float(props["wf_increment"])
        if not dt > 0:
            raise DataError(f"{self.path}: channel '{name}'",
                            f"field 'wf_increment' = {dt} s is not positive")
        epoch = props.get("wf_start_time")
        epoch = None if epoch is None else np.datetime64(epoch, "ns")
        return float(props.get("wf_start_offset", 0.0)), dt, epoch


class TdmsColumn:
    """Block-wise access to a TDMS channel, or to column ``k`` of ``ncol`` interleaved in
    an ``NI_ArrayColumn`` column-0 channel.

    Parameters
    ----------
    channel : nptdms.TdmsChannel
        The channel that holds the data.
    k, ncol : int
        Column index and column count (0 and 1 for an ordinary channel).
    source : str
        ``file: channel`` for error messages.
    """

    def __init__(self, channel, k: int, ncol: int, source: str) -> None:
        total = len(channel)
        if total % ncol:
            raise DataError(source, f"interleaved columns: {total} values in the channel "
                            f"that holds them is not a multiple of {ncol} columns (check "
                            f"the column list: interleaved:, or NI_ArrayColumn)")
        self.channel, self.k, self.ncol, self.source = channel, k, ncol, source
        self.size = total // ncol

    def read(self, start: int, stop: int) -> np.ndarray:
        """Samples ``start … stop-1`` as float64, read in blocks of :data:`BLOCK` values."""
        stop = min(stop, self.size)
        out = np.empty(max(stop - start, 0))
        step = BLOCK - BLOCK % self.ncol
        first, last = start * self.ncol, stop * self.ncol
        try:
            for pos in range(first, last, step):
                block = self.channel.read_data(offset=pos, length=min(step, last - pos))
                at = (pos - first) // self.ncol
                out[at:at + block.size // self.ncol] = block[self.k::self.ncol]
        except (ValueError, EOFError, OSError) as exc:
            raise DataError(self.source, f"cannot read the data (truncated file?): "
                            f"{exc}") from exc
        return out
