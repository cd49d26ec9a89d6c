"""Delimited text (CSV, TSV, semicolon or blank separated) through pandas.

Addressing: the column header (a header row is required; ``header:`` gives its row
number, 0-based). A header ``name [unit]`` states the unit of its column; the channel is
then addressed by the whole header or by ``name`` alone. ``delimiter:`` defaults to the
one :class:`csv.Sniffer` finds in the first 64 kB; ``decimal: ","`` reads decimal commas.
Time base: ``time:`` (a column) or ``sample_rate:``.

The requested columns are read in one pass, in chunks of :data:`CHUNK` rows and only
those columns (``usecols``), so memory stays at one float64 copy of them. For long
records, :meth:`DelimitedSource.spill` writes the columns chunk by chunk to raw float64
files in a temporary folder (removed by ``close()``) and :meth:`DelimitedSource.stream`
reads them back block by block: memory stays at one chunk.
"""

from __future__ import annotations

import csv
import re
import tempfile
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path

import numpy as np
import pandas as pd

from gbpipe.errors import DataError
from gbpipe.measured.channels import Channel, find
from gbpipe.measured.columns import FileColumn, StreamChannel, attach_stream
from gbpipe.measured.formats.timebase_of import attach
from gbpipe.measured.spec import FileSpec

__all__ = ["DelimitedSource", "CHUNK"]

#: rows per chunk
CHUNK = 1 << 18
_UNIT = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\])]*)[\])]\s*$")
_DELIMS = ",;\t| "


class DelimitedSource:
    """Columns of one delimited text file (see the module docstring)."""

    def __init__(self, path: Path, fspec: FileSpec) -> None:
        self.path, self.fspec = path, fspec
        with open(path, newline="", encoding="utf-8", errors="replace") as fh:
            head = fh.read(1 << 16)
        lines = head.splitlines()
        if len(lines) <= fspec.header or not lines[fspec.header].strip():
            raise DataError(f"{path}: field 'header'", f"no header row at line "
                            f"{fspec.header + 1}")
        sep = fspec.delimiter
        if sep is None:
            try:
                sep = csv.Sniffer().sniff(head, delimiters=_DELIMS).delimiter
            except csv.Error:
                sep = ","
        self.sep = sep
        header_line = lines[fspec.header]
        cols = next(csv.reader([header_line], delimiter=sep))
        if len(cols) == 1:
            found = [d for d in _DELIMS if d in header_line.strip()]
            raise DataError(f"{path}: field 'delimiter'", f"the header row has a single "
                            f"column with delimiter {sep!r}; the line holds "
                            f"{', '.join(repr(d) for d in found) or 'no known delimiter'}: "
                            f"give delimiter: (header: {header_line[:60]!r})")
        self._headers = [c.strip() for c in cols]
        self._alias: dict[str, str] = {h: h for h in self._headers}
        self._units: dict[str, str | None] = {}
        for h in self._headers:
            m = _UNIT.match(h)
            self._units[h] = m["unit"].strip() if m else None
            if m and m["name"] and m["name"] not in self._alias:
                self._alias[m["name"]] = h
        self._cache: dict[str, np.ndarray] = {}
        self._spilled: dict[str, FileColumn] = {}
        self._spill_dir: tempfile.TemporaryDirectory | None = None

    def names(self) -> list[str]:
        return list(self._alias)

    def close(self) -> None:
        self._cache.clear()
        self._spilled.clear()
        if self._spill_dir is not None:
            self._spill_dir.cleanup()
            self._spill_dir = None

    def prefetch(self, names: list[str]) -> None:
        """Read the columns ``names`` (and the time column) in one chunked pass."""
        wanted = [w for w in self._wanted(names) if w not in self._cache]
        if not wanted:
            return
        parts: dict[str, list[np.ndarray]] = {w: [] for w in wanted}
        self._scan(wanted, lambda w, v: parts[w].append(v))
        for w in wanted:  # pop: one column's chunks and its concatenation at a time
            chunks = parts.pop(w)
            self._cache[w] = np.concatenate(chunks) if chunks else np.empty(0)

    def spill(self, names: list[str]) -> None:
        """Read the columns ``names`` (and the time column) in one chunked pass into raw
        float64 files in a temporary folder, for :meth:`stream`: memory stays at one
        chunk, whatever the length of the file."""
        wanted = [w for w in self._wanted(names) if w not in self._spilled]
        if not wanted:
            return
        if self._spill_dir is None:
            self._spill_dir = tempfile.TemporaryDirectory(prefix="gbpipe-spill-")
        paths = {w: Path(self._spill_dir.name) / f"{len(self._spilled) + i}.f64"
                 for i, w in enumerate(wanted)}
        with ExitStack() as stack:
            files = {w: stack.enter_context(open(p, "wb")) for w, p in paths.items()}
            self._scan(wanted, lambda w, v: v.tofile(files[w]))
        for w, p in paths.items():
            self._spilled[w] = FileColumn(p, p.stat().st_size // 8)

    def stream(self, name: str) -> StreamChannel:
        """The column ``name`` for block-wise reading (spilled to disk first, if
        :meth:`spill` has not done it yet)."""
        header = self._alias[find(name, self.names(), str(self.path))]
        self.spill([header])
        time = None
        if self.fspec.time is not None:
            time = self._spilled[self._wanted([])[0]]
        return attach_stream(self._spilled[header], self._units[header], self.fspec,
                             str(self.path), header, time)

    def _wanted(self, names: list[str]) -> list[str]:
        """Headers of ``names`` and of the time column, without repeats."""
        wanted = [self._alias[find(n, self.names(), str(self.path))] for n in names]
        if self.fspec.time is not None:
            wanted.insert(0, self._alias[find(self.fspec.time, self.names(),
                                              f"{self.path} (field 'time')")])
        return list(dict.fromkeys(wanted))

    def _scan(self, wanted: list[str], sink: Callable[[str, np.ndarray], object]) -> None:
        """One chunked pass over the columns ``wanted``: ``sink(header, values)`` per
        chunk and column."""
        try:
            for chunk in self._chunks(wanted, float):
                for w in wanted:
                    sink(w, chunk[w].to_numpy(float))
        except ValueError:
            self._locate_bad(wanted)
            raise

    def _chunks(self, wanted: list[str], dtype):
        reader = pd.read_csv(self.path, sep=self.sep, decimal=self.fspec.decimal,
                             header=self.fspec.header, usecols=lambda c: c.strip() in wanted,
                             chunksize=CHUNK, skipinitialspace=True, dtype=dtype,
                             engine="c" if len(self.sep) == 1 else "python")
        for chunk in reader:
            chunk.columns = [c.strip() for c in chunk.columns]
            yield chunk

    def _locate_bad(self, wanted: list[str]) -> None:
        """Raise the error naming the first cell that is not a number (slow path, only
        after the fast numeric reader failed)."""
        row = 0
        for chunk in self._chunks(wanted, str):
            for w in wanted:
                text = chunk[w].str.strip()
                if self.fspec.decimal != ".":
                    text = text.str.replace(self.fspec.decimal, ".", regex=False)
                num = pd.to_numeric(text, errors="coerce").to_numpy(float)
                blank = text.isna() | text.str.lower().isin(["nan", "", "na", "n/a"])
                bad = np.flatnonzero(np.isnan(num) & ~blank.to_numpy())
                if bad.size:
                    i = int(bad[0])
                    raise DataError(f"{self.path}: channel '{w}'", f"not a number: "
                                    f"{chunk[w].iloc[i]!r} (data row {row + i + 1}); wrong "
                                    f"decimal: or delimiter:?", sample=row + i)
            row += len(chunk)

    def _column(self, name: str) -> tuple[str, np.ndarray]:
        header = self._alias[find(name, self.names(), str(self.path))]
        if header not in self._cache:
            self.prefetch([header])
        return header, self._cache[header]

    def read(self, name: str) -> Channel:
        header, _ = self._column(name)
        values = self._cache.pop(header)  # handed over: the caller owns (and scales) it
        return attach(values, self._units[header], self.fspec, str(self.path), header,
                      lambda t: self._column(t)[1])
