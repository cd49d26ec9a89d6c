"""NI TDMS files through npTDMS, streamed.

Addressing: ``group/channel``. Time base, in order: the mapping's ``time:`` channel
(``group/channel``), else the channel's waveform properties ``wf_increment`` [s] with
``wf_start_offset`` [s] and ``wf_start_time`` (absolute), else the file's ``sample_rate:``.
Unit: the ``unit_string`` property.

The file is opened with :meth:`nptdms.TdmsFile.open`, which reads only the metadata; a
channel's data is then read in blocks of :data:`BLOCK` values and converted to float64
block by block, so memory stays at one float64 copy of the channels asked for.

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
from gbpipe.measured.formats.timebase_of import attach
from gbpipe.measured.spec import FileSpec

__all__ = ["TdmsSource", "BLOCK"]

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

    def _data(self, name: str, ch) -> np.ndarray:
        layout = self._array_column(ch)
        src, k, ncol = (ch, 0, 1) if layout is None else layout
        total = len(src)
        if total % ncol:
            raise DataError(f"{self.path}: channel '{name}'", f"NI_ArrayColumn layout: "
                            f"{total} values in column 0 is not a multiple of {ncol} columns")
        out = np.empty(total // ncol)
        step = BLOCK - BLOCK % ncol
        try:
            for start in range(0, total, step):
                block = src.read_data(offset=start, length=min(step, total - start))
                out[start // ncol:(start + block.size) // ncol] = block[k::ncol]
        except (ValueError, EOFError, OSError) as exc:
            raise DataError(f"{self.path}: channel '{name}'", f"cannot read the data "
                            f"(truncated file?): {exc}") from exc
        return out

    def read(self, name: str) -> Channel:
        name = find(name, self.names(), str(self.path))
        ch = self._channels[name]
        values = self._data(name, ch)
        unit = ch.properties.get("unit_string") or None
        props = ch.properties
        if self.fspec.time is None and "wf_increment" in props:
            dt = float(props["wf_increment"])
            if not dt > 0:
                raise DataError(f"{self.path}: channel '{name}'",
                                f"field 'wf_increment' = {dt} s is not positive")
            epoch = props.get("wf_start_time")
            epoch = None if epoch is None else np.datetime64(epoch, "ns")
            return Channel(values, unit, t0=float(props.get("wf_start_offset", 0.0)), dt=dt,
                           epoch=epoch)

        def read_time(tname: str) -> np.ndarray:
            tname = find(tname, self.names(), f"{self.path} (field 'time')")
            return self._data(tname, self._channels[tname])

        return attach(values, unit, self.fspec, str(self.path), name, read_time)
