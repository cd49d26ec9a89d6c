"""List every channel of a bench file, so the user can write the ``measured:`` mapping.

Each row: the address to use as ``channel:``, the number of samples, the time base
(rate and start for a uniform base, the span and median rate of a time channel, or
"none" when the mapping must give ``time:``/``sample_rate:``), the unit the file
states, min/max and the NaN count. When one channel holds every value and its length is
a multiple of a small column count, a hint suggests the ``interleaved:`` key.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from gbpipe.errors import DataError
from gbpipe.measured.formats import open_source
from gbpipe.measured.spec import FileSpec

__all__ = ["list_channels", "format_listing", "interleave_hint", "MAX_COLUMNS"]

#: largest column count :func:`interleave_hint` considers
MAX_COLUMNS = 16


def _timebase(ch) -> str:
    if ch.dt is not None:
        start = f", start {ch.t0:g} s" if ch.t0 else ""
        return f"{1.0 / ch.dt:g} Hz{start}"
    if ch.time is not None and ch.time.size > 1:
        d = np.median(np.diff(ch.time))
        return f"time {ch.time[0]:g}..{ch.time[-1]:g} s (~{1.0 / d:g} Hz)"
    return "none"


def list_channels(path: str | Path, fmt: str | None = None, *, time: str | None = None,
                  sample_rate: float | None = None) -> list[dict[str, Any]]:
    """One dict per channel of ``path``: name, length, timebase, unit, min, max, nan, and
    ``hint`` (:func:`interleave_hint`) on a channel that holds every value of the file.

    ``time`` and ``sample_rate`` are as in the file's mapping; without them, formats
    that carry no time base in the channel report ``"none"``.
    """
    p = Path(path)
    fspec = FileSpec(key="inspect", path=p.name, format=fmt, time=time,
                     sample_rate=sample_rate)
    src = open_source(fspec, p.parent)
    plain = None  # the same file with a dummy rate, for channels without a time base
    rows, hints = [], []
    try:
        names = src.names()
        src.prefetch(names)
        for name in names:
            try:
                ch = src.read(name)
                tb = _timebase(ch)
            except DataError as exc:
                if "no time base" not in str(exc):
                    raise
                if plain is None:
                    plain = open_source(FileSpec(key="inspect", path=p.name, format=fmt,
                                                 sample_rate=1.0), p.parent)
                    plain.prefetch(names)
                ch = plain.read(name)
                tb = "none (give time: or sample_rate:)"
            v = ch.values
            hint = interleave_hint(name, v)
            if hint:
                hints.append(hint)
            finite = v[np.isfinite(v)]
            rows.append({"name": name, "length": int(v.size), "timebase": tb,
                         "unit": ch.unit or "", "min": float(finite.min()) if finite.size
                         else float("nan"), "max": float(finite.max()) if finite.size
                         else float("nan"), "nan": int(v.size - finite.size)})
    finally:
        src.close()
        if plain is not None:
            plain.close()
    if len(hints) == 1 and sum(r["length"] > 0 for r in rows) == 1:
        # one channel holds every value, the others are empty or absent
        next(r for r in rows if r["length"])["hint"] = hints[0]
    return rows


def interleave_hint(name: str, values: np.ndarray) -> str | None:
    """A suggestion of the ``interleaved:`` key for a channel whose length is a multiple
    of a small column count (2 … :data:`MAX_COLUMNS`), or ``None``.

    Counts whose column 0 … n-1 includes a strictly increasing column (a time column, as
    loggers write first) are named first: they are the likely layouts.
    """
    counts = [n for n in range(2, MAX_COLUMNS + 1) if values.size % n == 0
              and values.size // n >= 2]
    if not counts:
        return None
    timed = [n for n in counts
             if any(np.all(np.diff(values[k::n]) > 0) for k in range(n))]
    likely = ", ".join(f"{n} (column {_first_increasing(values, n)} increases: a time "
                       f"column?)" for n in timed)
    others = ", ".join(str(n) for n in counts if n not in timed)
    what = f"likely {likely}" + (f"; also possible {others}" if others else "") if timed \
        else f"possible {others}"
    return (f"'{name}' holds {values.size} values and no other channel holds data: if "
            f"they are n columns interleaved row by row, map the file with interleaved: "
            f"[the n column names in order] (column k = values[k::n]); n = {what}")


def _first_increasing(values: np.ndarray, n: int) -> int:
    return next(k for k in range(n) if np.all(np.diff(values[k::n]) > 0))


def format_listing(rows: list[dict[str, Any]]) -> str:
    """The rows of :func:`list_channels` as an aligned text table."""
    head = ["channel", "length", "time base", "unit", "min", "max", "NaN"]
    body = [[r["name"], str(r["length"]), r["timebase"], r["unit"], f"{r['min']:.6g}",
             f"{r['max']:.6g}", str(r["nan"])] for r in rows]
    widths = [max(len(x) for x in col) for col in zip(head, *body, strict=False)]
    lines = ["  ".join(x.ljust(w) for x, w in zip(row, widths, strict=True)).rstrip()
             for row in [head, *body]]
    lines += [f"hint: {r['hint']}" for r in rows if r.get("hint")]
    return "\n".join(lines)
