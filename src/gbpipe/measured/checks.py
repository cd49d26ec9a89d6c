"""Checks of channel values: NaN or inf, clipping, length. Each error names the file,
the channel, and the sample index.

NaN is refused (or bridged under ``gaps: {interpolate_upto: N}``); clipping signs are
:class:`Finding` objects that :func:`enforce` turns into an error, a warning or nothing,
at the level the signal's ``checks:`` gives each check.

:func:`finite` and :func:`clipping` check an array in memory; :func:`scan` makes the same
checks on a :class:`gbpipe.measured.columns.Column` read block by block (long records),
with runs that span blocks followed by :class:`RunTracker`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from gbpipe.errors import DataError
from gbpipe.measured.columns import Column, blocks

__all__ = ["finite", "clipping", "enforce", "Finding", "length", "scan", "Bridged",
           "RunTracker", "CLIP_RUN", "BLOCK"]

log = logging.getLogger(__name__)

#: this many equal consecutive samples at the channel's extreme count as a flat top
CLIP_RUN = 5
#: samples per block of the streamed checks (8 MB of float64)
BLOCK = 1 << 20


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start indices and lengths of the runs of True in ``mask``."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(m))
    return edges[::2], edges[1::2] - edges[::2]


def finite(values: np.ndarray, source: str, bridge_upto: int = 0) -> np.ndarray:
    """Refuse NaN or inf samples, or bridge runs of at most ``bridge_upto`` linearly.

    Returns
    -------
    numpy.ndarray
        ``values``, with bridged runs filled.

    Raises
    ------
    gbpipe.errors.DataError
        At the first run that is not bridged (its start index and length).
    """
    bad = ~np.isfinite(values)
    if not bad.any():
        return values
    _refuse_nan(*_runs(bad), values.size, int(bad.sum()), source, bridge_upto)
    good = np.flatnonzero(~bad)
    out = values.copy()
    out[bad] = np.interp(np.flatnonzero(bad), good, values[good])
    return out


@dataclass(frozen=True)
class Finding:
    """A clipping sign in a channel: ``check`` (``"range"`` or ``"flat_top"``), what was
    seen (with how many samples) and its first sample."""

    check: str
    what: str
    sample: int


def clipping(values: np.ndarray,
             converter_range: tuple[float, float] | None = None, *,
             flat_top: bool = True) -> list[Finding]:
    """Signs of clipping in a channel, for :func:`enforce` to judge.

    Two signs: samples at or beyond ``converter_range`` (when the mapping gives the
    converter's range: clipping for sure), and a flat top — :data:`CLIP_RUN` or more
    consecutive samples equal to the channel's maximum or minimum. A saturated converter
    gives a flat top, but so does a set-point resting at 0 or a reading the drive
    updates every few ms: a flat top alone is only a hint. ``flat_top=False`` skips it.
    """
    found: list[Finding] = []
    if values.size == 0:
        return found
    if converter_range is not None:
        at = np.flatnonzero(_beyond(values, converter_range))
        if at.size:
            found.append(_range_finding(converter_range, at.size, int(at[0])))
    if flat_top and values.max() > values.min():
        for extreme, word in ((values.max(), "maximum"), (values.min(), "minimum")):
            starts, lengths = _runs(values == extreme)
            long_ = np.flatnonzero(lengths >= CLIP_RUN)
            if long_.size:
                i = long_[0]
                found.append(_flat_finding(int(lengths[i]), word, extreme, long_.size,
                                           int(starts[i])))
    return found


def enforce(findings: list[Finding], levels: Mapping[str, str], source: str,
            time_of: Callable[[int], float]) -> list[str]:
    """Judge :func:`clipping` findings at the signal's check ``levels``.

    Parameters
    ----------
    findings : list of Finding
        From :func:`clipping` or :func:`scan`.
    levels : mapping
        Check name -> ``"off"``, ``"warn"`` or ``"error"`` (the signal's ``checks``).
    source : str
        ``file: channel``, for the messages.
    time_of : callable
        Sample index -> its time [s] on the file's clock.

    Returns
    -------
    list of str
        The warnings (also logged), each with its sample index, time and length.

    Raises
    ------
    gbpipe.errors.DataError
        At the first finding whose check is at level ``"error"``.
    """
    warnings = []
    for f in findings:
        level = levels[f.check]
        if level == "off":
            continue
        where = f"from sample {f.sample} (t = {time_of(f.sample):.9g} s on the file's clock)"
        if level == "error":
            raise DataError(source, f"clipped: {f.what}, {where}; {_FIX[f.check]}",
                            sample=f.sample)
        text = f"possible clipping ({f.check}): {f.what}, {where}"
        log.warning("%s: %s; %s", source, text, _WARN_HINT[f.check])
        warnings.append(text)
    return warnings


_FIX = {"range": "the converter saturated: lower the gain or widen its range, or correct "
                 "range: (checks: {range: warn} keeps the record)",
        "flat_top": "a saturated converter gives this: lower the gain or widen its range; "
                    "a signal that rests at its extreme (a set-point, a held reading) is "
                    "quantity: setpoint or checks: {flat_top: warn}"}
_WARN_HINT = {"range": "the record is kept (checks: {range: warn})",
              "flat_top": "declare the converter's range: to check it for sure; a held "
                          "signal is quantity: setpoint (no flat-top check)"}


def _refuse_nan(starts: np.ndarray, lengths: np.ndarray, size: int, n_bad: int, source: str,
                bridge_upto: int) -> None:
    """Raise at the first NaN run that is not bridged: longer than ``bridge_upto``, or at
    an end of the ``size`` samples (nothing to bridge from)."""
    over = np.flatnonzero((lengths > bridge_upto) | (starts == 0)
                          | (starts + lengths == size))
    if over.size:
        i = over[0]
        why = "" if not bridge_upto else f" (longer than interpolate_upto = {bridge_upto}, " \
            "or at an end)"
        fix = ("cut the record before it, or re-export the file without the dropout" if
               bridge_upto else f"bridge runs of up to N samples with gaps: "
               f"{{interpolate_upto: N}} (this one needs N >= {lengths[i]}), or cut the "
               f"record before it")
        raise DataError(source, f"{lengths[i]} NaN/inf sample(s){why}; {n_bad} in all; "
                        f"fix: {fix}", sample=int(starts[i]))


def _beyond(values: np.ndarray, converter_range: tuple[float, float]) -> np.ndarray:
    return (values <= converter_range[0]) | (values >= converter_range[1])


def _range_finding(converter_range: tuple[float, float], count: int,
                   first: int) -> Finding:
    lo, hi = converter_range
    return Finding("range", f"{count} sample(s) at or beyond the converter range "
                   f"[{lo:g}, {hi:g}] (field 'range')", first)


def _flat_finding(n: int, word: str, extreme: float, runs: int, first: int) -> Finding:
    return Finding("flat_top", f"flat top of {n} samples at the {word} {extreme:g} "
                   f"({runs} such run(s))", first)


def length(n: int, fs: float, source: str, min_duration: float | None) -> None:
    """Refuse an empty record, or one shorter than ``min_duration`` [s]."""
    if n < 2:
        raise DataError(source, f"{n} sample(s) on the record grid: nothing to analyse")
    if min_duration is not None and n / fs < min_duration:
        raise DataError(source, f"too short: {n / fs:.6g} s ({n} samples at {fs:g} Hz); "
                        f"the analysis needs at least {min_duration:.6g} s")


class RunTracker:
    """Runs of True in a boolean sequence fed block by block (runs may span blocks).

    ``feed(mask, offset)`` returns the runs that ended, as arrays of absolute start
    indices and lengths; :meth:`finish` returns the one still open at the end.
    """

    def __init__(self) -> None:
        self.open: tuple[int, int] | None = None

    def feed(self, mask: np.ndarray, offset: int) -> tuple[np.ndarray, np.ndarray]:
        starts, lengths = _runs(mask)
        starts = starts + offset
        if self.open is not None:
            if mask.size and mask[0]:
                starts[0], lengths[0] = self.open[0], lengths[0] + self.open[1]
            else:
                starts = np.concatenate([[self.open[0]], starts])
                lengths = np.concatenate([[self.open[1]], lengths])
            self.open = None
        if mask.size and mask[-1]:
            self.open = (int(starts[-1]), int(lengths[-1]))
            starts, lengths = starts[:-1], lengths[:-1]
        return starts, lengths

    def finish(self) -> tuple[np.ndarray, np.ndarray]:
        run, self.open = self.open, None
        return (np.array([run[0]]), np.array([run[1]])) if run else (np.empty(0, int),
                                                                    np.empty(0, int))


def scan(column: Column, source: str, bridge_upto: int = 0,
         converter_range: tuple[float, float] | None = None, *, flat_top: bool = True,
         block: int | None = None) -> tuple[Bridged, list[Finding]]:
    """:func:`finite` and :func:`clipping` of a column read block by block.

    The same checks, messages and findings, with absolute sample indices; two passes
    over the column (the flat-top test needs the channel's extremes first).

    Returns
    -------
    Bridged
        The column with its bridged NaN runs filled.
    list of Finding
        The clipping signs, for :func:`enforce`.
    """
    block = BLOCK if block is None else block
    nan, nan_runs = RunTracker(), []
    lo_hi, n_bad, n_clip, first_clip = [np.inf, -np.inf], 0, 0, -1
    for a, b in blocks(column.size, block):
        v = column.read(a, b)
        bad = ~np.isfinite(v)
        n_bad += int(bad.sum())
        nan_runs.append(nan.feed(bad, a))
        good = v[~bad]
        if good.size:
            lo_hi = [min(lo_hi[0], good.min()), max(lo_hi[1], good.max())]
        if converter_range is not None:
            at = np.flatnonzero(_beyond(v, converter_range))
            n_clip += at.size
            if at.size and first_clip < 0:
                first_clip = a + int(at[0])
    nan_runs.append(nan.finish())
    starts = np.concatenate([s for s, _ in nan_runs]).astype(np.int64)
    lengths = np.concatenate([n for _, n in nan_runs]).astype(np.int64)
    _refuse_nan(starts, lengths, column.size, n_bad, source, bridge_upto)
    found = [_range_finding(converter_range, n_clip, first_clip)] if n_clip else []
    bridged = Bridged(column, starts, lengths)
    if flat_top and lo_hi[1] > lo_hi[0]:
        found += _flat_tops(bridged, lo_hi, block)
    return bridged, found


def _flat_tops(column: Bridged, lo_hi: list[float], block: int) -> list[Finding]:
    """The flat-top part of :func:`clipping`, second pass over the column."""
    trackers = {"maximum": RunTracker(), "minimum": RunTracker()}
    extremes = {"maximum": lo_hi[1], "minimum": lo_hi[0]}
    long_runs: dict[str, list[tuple[int, int]]] = {"maximum": [], "minimum": []}
    count = dict.fromkeys(trackers, 0)

    def collect(word: str, runs: tuple[np.ndarray, np.ndarray]) -> None:
        keep = runs[1] >= CLIP_RUN
        count[word] += int(keep.sum())
        if keep.any() and not long_runs[word]:
            k = int(np.flatnonzero(keep)[0])
            long_runs[word].append((int(runs[0][k]), int(runs[1][k])))

    for a, b in blocks(column.size, block):
        v = column.read(a, b)
        for word, tracker in trackers.items():
            collect(word, tracker.feed(v == extremes[word], a))
    found = []
    for word, tracker in trackers.items():
        collect(word, tracker.finish())
        if long_runs[word]:
            start, n = long_runs[word][0]
            found.append(_flat_finding(n, word, extremes[word], count[word], start))
    return found


class Bridged:
    """A column whose NaN runs (accepted by :func:`scan`) are filled linearly between
    their neighbours, as :func:`finite` fills them."""

    def __init__(self, column: Column, starts: np.ndarray, lengths: np.ndarray) -> None:
        self.column, self.size = column, column.size
        self.starts, self.lengths = starts, lengths

    def read(self, start: int, stop: int) -> np.ndarray:
        v = self.column.read(start, stop)
        first = np.searchsorted(self.starts + self.lengths, start, side="right")
        last = np.searchsorted(self.starts, stop, side="left")
        for s, n in zip(self.starts[first:last], self.lengths[first:last], strict=True):
            ends = [s - 1, s + n]
            around = [v[e - start] if start <= e < stop else self.column.read(e, e + 1)[0]
                      for e in ends]
            idx = np.arange(max(s, start), min(s + n, stop))
            v[idx - start] = np.interp(idx, ends, around)
        return v
