"""Time bases of bench channels: clock checks, overlap window, resampling to the record grid.

A channel becomes a list of :class:`Piece` — contiguous runs of uniformly spaced samples
on the common clock. :func:`pieces` finds, on an explicit time channel, gaps (refused,
split at, or bridged when at most ``interpolate_upto`` samples are missing) and backward
steps: a clock reset, as a logger restarting its clock does. With ``gaps: split`` a reset
starts a new run of a new clock *era*, else it is refused; a repeated stamp is always
refused. It fits a uniform clock through the stamps of each run, so logging jitter of up
to :data:`JITTER` sample does not become signal noise. :func:`unroll` then places each era
after the one before on the common clock, where every file resets alike (the same
resets, at the same moments); where the files' clocks would disagree after a reset, it
refuses naming the files and the sample. :func:`overlap` intersects the channels'
windows; :func:`resample` (from :mod:`gbpipe.measured.resample`, where the anti-aliased
resampling is described) puts a piece on the record's uniform grid.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from gbpipe.errors import DataError
from gbpipe.measured import checks
from gbpipe.measured.columns import Column, blocks
from gbpipe.measured.resample import HALF_TAPS, resample, sinc_interpolate

__all__ = ["Piece", "pieces", "scan_clock", "unroll", "overlap", "intersect", "resample",
           "sinc_interpolate", "HALF_TAPS", "GAP_FACTOR", "JITTER"]

#: largest deviation of a time stamp from the fitted uniform clock [sample intervals]
JITTER = 0.35
#: an interval longer than this many nominal sample intervals is a gap (above the
#: 1 + 2 JITTER that jitter alone can produce)
GAP_FACTOR = 1.75


@dataclass
class Piece:
    """Uniformly sampled run: sample ``k`` at ``t0 + k * dt`` [s] on the common clock.

    ``first`` is the channel's index of sample 0, ``era`` the number of clock resets in
    the channel before the run (:func:`unroll`).
    """

    values: np.ndarray
    t0: float
    dt: float
    first: int = 0
    era: int = 0

    @property
    def end(self) -> float:
        """Time of the last sample [s]."""
        return self.t0 + (self.values.size - 1) * self.dt


def _fit_clock(t: np.ndarray, source: str, first: int) -> tuple[float, float]:
    """Least-squares uniform clock ``t ≈ a + b k`` through a gap-free run of stamps."""
    if t.size < 2:
        raise DataError(source, "a run of fewer than 2 samples between gaps", sample=first)
    # Closed-form least squares on k = 0..n-1 (no n-by-2 design matrix: long records).
    n = t.size
    kc = np.arange(n, dtype=float) - 0.5 * (n - 1)
    b = float(kc @ t) / (n * (n * n - 1) / 12.0)
    a = float(t.mean()) - b * 0.5 * (n - 1)
    kc += 0.5 * (n - 1)
    kc *= b
    kc += a
    dev = np.abs(t - kc)
    worst = int(np.argmax(dev))
    _check_jitter(source, float(dev[worst]), b, first + worst)
    return float(a), float(b)


def _check_jitter(source: str, dev: float, dt: float, sample: int) -> None:
    if dev > JITTER * dt:
        raise DataError(source, f"sample times deviate from a uniform clock by "
                        f"{dev / dt:.2f} sample intervals (irregular sampling, or a short "
                        f"gap); gbpipe accepts jitter up to {JITTER}", sample=sample)


def _backward(source: str, step: float, i: int, t_i: float) -> DataError:
    if step == 0:
        return DataError(f"{source} (time)", f"time repeats (duplicate stamp) between "
                         f"samples {i} and {i + 1}, at t = {t_i:.6g} s: remove the "
                         "repeated row", sample=i + 1)
    return DataError(f"{source} (time)", f"time jumps backwards by {-step:.6g} s (a clock "
                     f"reset, or unsorted rows: time is not monotonic) between samples {i} "
                     f"and {i + 1}, at t = {t_i:.6g} s; a logger's clock reset starts a new "
                     "segment with gaps: split (else split the file at the reset)",
                     sample=i + 1)


def _gap(source: str, step: float, dt_nom: float, missing: int, allow: str, i: int,
         t_i: float, count: int) -> DataError:
    return DataError(f"{source} (time)", f"gap of {step - dt_nom:.6g} s ({missing} missing "
                     f"samples{allow}) after t = {t_i:.6g} s; {count} gap(s) in all. Set "
                     f"gaps: split or {{interpolate_upto: N}} to accept them", sample=i + 1)


def pieces(values: np.ndarray, source: str, *, t0: float | None = None,
           dt: float | None = None, time: np.ndarray | None = None, gaps: str = "refuse",
           interpolate_upto: int = 0) -> list[Piece]:
    """Split a channel into uniformly sampled pieces, checking its clock.

    Parameters
    ----------
    values : numpy.ndarray
        Samples.
    source : str
        ``file: channel`` for error messages.
    t0, dt : float, optional
        Uniform time base (then ``time`` is ``None``).
    time : numpy.ndarray, optional
        Sample times [s] on the common clock.
    gaps : {"refuse", "split", "interpolate"}
        What a gap in ``time`` does; with ``"split"`` a backward step (a clock reset)
        also starts a new run, of the next era.
    interpolate_upto : int
        With ``gaps="interpolate"``, the most missing samples bridged (linearly: a gap of
        a few samples carries no information a better interpolant could restore).

    Raises
    ------
    gbpipe.errors.DataError
        On non-finite or repeated times, a backward step unless ``gaps="split"`` (with
        the sample index and the jump size), and on a gap the policy does not allow.
    """
    if time is None:
        return [Piece(values, float(t0), float(dt))]
    t = np.asarray(time, dtype=float)
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise DataError(f"{source} (time)", "time stamp is NaN or inf", sample=int(bad[0]))
    d = np.diff(t)
    back = np.flatnonzero(d <= 0)
    if back.size and (gaps != "split" or np.any(d[back] == 0)):
        i = int(back[0] if gaps != "split" else back[d[back] == 0][0])
        raise _backward(source, float(d[i]), i, float(t[i]))
    dt_nom = float(np.median(d))
    gap_at = np.flatnonzero(d > GAP_FACTOR * dt_nom)
    missing = np.rint(d[gap_at] / dt_nom).astype(int) - 1
    if gap_at.size and gaps == "refuse" or (gaps == "interpolate" and
                                             np.any(missing > interpolate_upto)):
        j = 0 if gaps == "refuse" else int(np.flatnonzero(missing > interpolate_upto)[0])
        i = int(gap_at[j])
        allow = ("" if gaps == "refuse" else
                 f", more than interpolate_upto = {interpolate_upto}")
        raise _gap(source, float(d[i]), dt_nom, int(missing[j]), allow, i, float(t[i]),
                   len(gap_at))
    if gaps == "interpolate" and gap_at.size:
        # Insert the missing stamps on the nominal clock and bridge the values linearly.
        k = np.concatenate([[0], np.cumsum(np.rint(d / dt_nom).astype(int))])
        full_k = np.arange(k[-1] + 1)
        t = np.interp(full_k, k, t)
        values = np.interp(full_k, k, values)
        gap_at = np.empty(0, dtype=int)
    out, start, era = [], 0, 0
    resets = set((back + 1).tolist())
    for stop in [*sorted({*(gap_at + 1).tolist(), *resets}), t.size]:
        a, b = _fit_clock(t[start:stop], f"{source} (time)", start)
        era += start in resets
        out.append(Piece(values[start:stop], a, b, start, era))
        start = stop
    return out


def unroll(channels: Mapping[str, Sequence]) -> None:
    """Place each clock era after the one before on the common clock (pieces in place).

    After a reset a channel's stamps start again from an earlier time; the runs of era
    ``k`` are shifted by one offset for every channel, so that they begin one sample
    interval (the slowest channel's) after the latest sample of era ``k - 1``: how long
    the logger stood between the eras is not in the files, so the record's time axis
    puts nothing there, and ``gaps: split`` numbers the eras' runs as segments. Every
    channel must reset alike, or the files no longer share one clock after it.

    Parameters
    ----------
    channels : mapping
        Source label (``file: channel``, for messages) -> its pieces, each with ``t0``,
        ``end``, ``dt`` [s], ``first`` (sample index) and ``era``.

    Raises
    ------
    gbpipe.errors.DataError
        A channel whose clock resets where another's does not (a different count, or a
        reset more than one sample interval away), naming both and the sample.
    """
    eras = {label: max(p.era for p in plist) for label, plist in channels.items()}
    n = max(eras.values())
    if n == 0:
        return
    ref = next(label for label, k in eras.items() if k == n)
    slowest = max(p.dt for plist in channels.values() for p in plist)
    shift = 0.0
    for k in range(1, n + 1):
        ref_reset = _reset(channels[ref], k)
        moments = {}
        for label, plist in channels.items():
            reset = _reset(plist, k) if eras[label] >= k else None
            tol = (1 + 2 * JITTER) * max(plist[0].dt, channels[ref][0].dt)
            if reset is None or max(abs(reset[0] - ref_reset[0]),
                                    abs(reset[1] - ref_reset[1])) > tol:
                seen = ("runs on without it" if reset is None else
                        f"resets at its sample {reset[2]} (t = {reset[0]:.6g} s -> "
                        f"{reset[1]:.6g} s)")
                raise DataError(f"{ref} (time)", f"the clock resets at sample "
                                f"{ref_reset[2]} (t = {ref_reset[0]:.6g} s -> "
                                f"{ref_reset[1]:.6g} s), but {label} {seen}: after the "
                                "reset the files no longer share one clock; cut the files "
                                "at the reset and map each part as a record of its own",
                                sample=ref_reset[2])
            moments[label] = reset
        before = max(m[0] for m in moments.values())
        after = min(m[1] for m in moments.values())
        shift += before + slowest - after
        for plist in channels.values():
            for p in plist:
                if p.era == k:
                    p.t0 += shift


def _reset(plist: Sequence, k: int) -> tuple[float, float, int]:
    """(last time of era ``k - 1``, first time of era ``k``, its first sample) [s]."""
    last = max(p.end for p in plist if p.era == k - 1)
    first = min((p for p in plist if p.era == k), key=lambda p: p.first)
    return last, first.t0, first.first


def overlap(windows: dict[str, tuple[float, float]], unit: str = "s") -> tuple[float, float]:
    """Common window of several ``label -> (start, end)`` windows.

    Raises
    ------
    gbpipe.errors.DataError
        When they do not overlap: the message lists every window.
    """
    start = max(w[0] for w in windows.values())
    end = min(w[1] for w in windows.values())
    if end <= start:
        # + 0.0: a clock fitted to -1e-17 s prints as 0, not -0
        listing = "; ".join(f"{k}: [{round(a, 9) + 0.0:.6g}, {round(b, 9) + 0.0:.6g}] {unit}"
                            for k, (a, b) in windows.items())
        raise DataError("record", f"the files do not overlap in time (latest start "
                        f"{start:.6g} {unit} is after earliest end {end:.6g} {unit}). "
                        f"Windows: {listing}")
    return start, end


def intersect(a: list[tuple[float, float]],
              b: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Intersection of two sorted lists of disjoint closed intervals."""
    out = []
    for a0, a1 in a:
        for b0, b1 in b:
            lo, hi = max(a0, b0), min(a1, b1)
            if hi > lo:
                out.append((lo, hi))
    return sorted(out)


def scan_clock(time: Column, source: str, *, shift: float = 0.0, gaps: str = "refuse",
               block: int | None = None) -> list[tuple[int, int, float, float]]:
    """:func:`pieces` for a time channel read block by block (long records).

    The same checks and messages with absolute sample indices, in two passes: stamps,
    steps, gaps and the least-squares sums of each run's clock; then each run's jitter
    about its fitted clock. ``gaps`` is ``"refuse"`` or ``"split"`` (bridging gaps needs
    the channel in memory: :func:`pieces`); with ``"split"`` a clock reset starts a run of
    the next era, as in :func:`pieces`. The nominal interval that defines a gap is
    the median interval of the first block (of the whole channel in :func:`pieces`).

    Parameters
    ----------
    time : Column
        Sample times [s] on the file's clock.
    source : str
        ``file: channel`` for error messages.
    shift : float
        Seconds added to put the times on the common clock.

    Returns
    -------
    list of (first, stop, t0, dt, era)
        Sample index range ``[first, stop)`` of each gap-free run and its fitted uniform
        clock: sample ``first + k`` at ``t0 + k dt`` [s] on the common clock; ``era`` the
        clock resets before it.
    """
    block = checks.BLOCK if block is None else block  # read now: tests make it small
    n = time.size
    dt_nom = None
    prev = None
    bad = back = None
    gap_at: list[int] = []
    gap_step: list[float] = []
    reset_at: list[int] = []
    sums = [[0, 0.0, 0.0, None]]  # per run: first index, sum t', sum k t', t_ref
    for a, b in blocks(n, block):
        t = time.read(a, b) + shift
        nonfinite = np.flatnonzero(~np.isfinite(t))
        if nonfinite.size:
            bad = a + int(nonfinite[0])
            break
        tt = t if prev is None else np.concatenate([[prev], t])
        d = np.diff(tt)
        base = a if prev is None else a - 1  # tt[i] is sample base + i
        if dt_nom is None:
            dt_nom = float(np.median(d)) if d.size else 0.0
        down = np.flatnonzero(d < 0 if gaps == "split" else d <= 0)
        same = np.flatnonzero(d == 0)
        refused = same if gaps == "split" else down
        if refused.size and back is None:
            i = int(refused[0])
            back = (float(d[i]), base + i, float(tt[i]))
        new = np.flatnonzero(d > GAP_FACTOR * dt_nom)
        gap_at += (base + new).tolist()
        gap_step += d[new].tolist()
        if gaps == "split":
            reset_at += (base + down + 1).tolist()
        _accumulate(sums, t, a, sorted((base + np.concatenate([new, down]) + 1).tolist()))
        prev = t[-1]
    if bad is not None:
        raise DataError(f"{source} (time)", "time stamp is NaN or inf", sample=bad)
    if back is not None:
        raise _backward(source, *back)
    if gap_at and gaps != "split":
        i = gap_at[0]
        t_i = float(time.read(i, i + 1)[0]) + shift
        raise _gap(source, gap_step[0], dt_nom, int(np.rint(gap_step[0] / dt_nom)) - 1, "",
                   i, t_i, len(gap_at))
    bounds = [0, *sorted({*(g + 1 for g in gap_at), *reset_at}), n]
    runs = []
    for (first, s_t, s_kt, t_ref), stop in zip(sums, bounds[1:], strict=True):
        m = stop - first
        if m < 2:
            raise DataError(f"{source} (time)", "a run of fewer than 2 samples between gaps",
                            sample=first)
        # the closed form of _fit_clock, from sums of the stamps less the first one
        slope = (s_kt - 0.5 * (m - 1) * s_t) / (m * (m * m - 1) / 12.0)
        era = sum(r <= first for r in reset_at)
        runs.append((first, stop, t_ref + s_t / m - slope * 0.5 * (m - 1), slope, era))
    for first, stop, t0, dt, _ in runs:
        worst, at = -1.0, first
        for a, b in blocks(stop - first, block):
            k = np.arange(a, b, dtype=float)
            k *= dt
            k += t0
            dev = np.abs(time.read(first + a, first + b) + shift - k)
            i = int(np.argmax(dev))
            if dev[i] > worst:
                worst, at = float(dev[i]), first + a + i
        _check_jitter(f"{source} (time)", worst, dt, at)
    return runs


def _accumulate(sums: list[list], t: np.ndarray, a: int, starts: list[int]) -> None:
    """Add the stamps ``t`` (samples ``a …``) to the least-squares sums of their runs
    (``[first, sum t', sum k t', t_ref]`` with ``t' = t - t_ref``, ``k`` from the run's
    first sample); ``starts`` are the first samples of the runs that begin in this block."""
    edges = [a, *starts, a + t.size]
    for idx, (lo, hi) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
        if idx > 0:
            sums.append([lo, 0.0, 0.0, None])
        if hi == lo:
            continue
        run = sums[-1]
        if run[3] is None:
            run[3] = float(t[lo - a])
        seg = t[lo - a:hi - a] - run[3]
        run[1] += float(seg.sum())
        run[2] += float(np.arange(lo - run[0], hi - run[0], dtype=float) @ seg)
