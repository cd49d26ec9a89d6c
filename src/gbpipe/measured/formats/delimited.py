"""Delimited text (CSV, TSV, semicolon or blank separated) through pandas.

Addressing: the column header (a header row is required; ``header:`` gives its row
number, 0-based). A header ``name [unit]`` states the unit of its column; the channel is
then addressed by the whole header or by ``name`` alone. ``delimiter:`` defaults to the
one :class:`csv.Sniffer` finds in the first 64 kB; ``decimal: ","`` reads decimal commas.
Time base: ``time:`` (a column) or ``sample_rate:``.

The requested columns are read in one pass, in chunks of :data:`CHUNK` rows and only
those columns (``usecols``), so memory stays at one float64 copy of them.
"""

from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np
import pandas as pd

from gbpipe.errors import DataError
from gbpipe.measured.channels import Channel, find
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

    def names(self) -> list[str]:
        return list(self._alias)

    def close(self) -> None:
        self._cache.clear()

    def prefetch(self, names: list[str]) -> None:
        """Read the columns ``names`` (and the time column) in one chunked pass."""
        wanted = [self._alias[find(n, self.names(), str(self.path))] for n in names]
        if self.fspec.time is not None:
            wanted.append(self._alias[find(self.fspec.time, self.names(),
                                           f"{self.path} (field 'time')")])
        wanted = [w for w in dict.fromkeys(wanted) if w not in self._cache]
        if not wanted:
            return
        parts: dict[str, list[np.ndarray]] = {w: [] for w in wanted}
        try:
            for chunk in self._chunks(wanted, float):
                for w in wanted:
                    parts[w].append(chunk[w].to_numpy(float))
        except ValueError:
            self._locate_bad(wanted)
            raise
        for w in wanted:  # pop: one column's chunks and its concatenation at a time
            chunks = parts.pop(w)
            self._cache[w] = np.concatenate(chunks) if chunks else np.empty(0)

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
