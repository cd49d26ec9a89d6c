"""Time bases of bench channels: clock checks, overlap window, resampling to the record grid.

A channel becomes a list of :class:`Piece` — contiguous runs of uniformly spaced samples
on the common clock. :func:`pieces` finds, on an explicit time channel, backward jumps
(always refused: after a clock reset the channel no longer shares the other files'
clock), gaps (refused, split at, or bridged when at most ``interpolate_upto`` samples are
missing), and fits a uniform clock through the stamps of each run, so logging jitter
of up to :data:`JITTER` sample does not become signal noise. :func:`overlap` intersects the
channels' windows; :func:`resample` puts a piece on the record's uniform grid.

Resampling is never nearest-sample: when the two rates have a small rational ratio
``up/down`` the signal goes through :func:`scipy.signal.resample_poly` (a polyphase FIR
with its own anti-aliasing low-pass, here a Kaiser window of β = 8.6: -80 dB stop band,
gain flat to 1e-5 up to 0.6 of the output Nyquist frequency, 1e-2 at 0.8) and, if the
grids are offset by a fraction of a sample, through a band-limited (Kaiser-windowed
sinc) fractional delay; otherwise the windowed-sinc interpolator is used directly, with
its cut-off lowered to the lower of the two Nyquist frequencies. The first and last
:data:`HALF_TAPS` samples of a piece are within one filter length of its edge and carry
the usual edge transient.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from scipy.signal import resample_poly

from gbpipe.errors import DataError

__all__ = ["Piece", "pieces", "overlap", "intersect", "resample", "sinc_interpolate",
           "HALF_TAPS", "GAP_FACTOR", "JITTER"]

#: half length of the windowed-sinc kernel [samples]
HALF_TAPS = 16
#: largest deviation of a time stamp from the fitted uniform clock [sample intervals]
JITTER = 0.35
#: an interval longer than this many nominal sample intervals is a gap (above the
#: 1 + 2 JITTER that jitter alone can produce)
GAP_FACTOR = 1.75
_KAISER_BETA = 8.6  # -80 dB side lobes
_BLOCK = 1 << 16    # output samples per interpolation block (bounded memory)


@dataclass
class Piece:
    """Uniformly sampled run: sample ``k`` at ``t0 + k * dt`` [s] on the common clock."""

    values: np.ndarray
    t0: float
    dt: float

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
    if dev[worst] > JITTER * b:
        raise DataError(source, f"sample times deviate from a uniform clock by "
                        f"{dev[worst] / b:.2f} sample intervals (irregular sampling, or a "
                        f"short gap); gbpipe accepts jitter up to {JITTER}",
                        sample=first + worst)
    return float(a), float(b)


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
        What a gap in ``time`` does.
    interpolate_upto : int
        With ``gaps="interpolate"``, the most missing samples bridged (linearly: a gap of
        a few samples carries no information a better interpolant could restore).

    Raises
    ------
    gbpipe.errors.DataError
        On non-finite or non-increasing times (with the sample index and the jump size),
        and on a gap the policy does not allow.
    """
    if time is None:
        return [Piece(values, float(t0), float(dt))]
    t = np.asarray(time, dtype=float)
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise DataError(f"{source} (time)", "time stamp is NaN or inf", sample=int(bad[0]))
    d = np.diff(t)
    back = np.flatnonzero(d <= 0)
    if back.size:
        i = int(back[0])
        what = ("time repeats (duplicate stamp)" if d[i] == 0 else
                f"time jumps backwards by {-d[i]:.6g} s (a clock reset, or unsorted rows: "
                f"time is not monotonic)")
        raise DataError(f"{source} (time)", f"{what} between samples {i} and {i + 1}, at "
                        f"t = {t[i]:.6g} s; split the file at the reset", sample=i + 1)
    dt_nom = float(np.median(d))
    gap_at = np.flatnonzero(d > GAP_FACTOR * dt_nom)
    missing = np.rint(d[gap_at] / dt_nom).astype(int) - 1
    if gap_at.size and gaps == "refuse" or (gaps == "interpolate" and
                                             np.any(missing > interpolate_upto)):
        j = 0 if gaps == "refuse" else int(np.flatnonzero(missing > interpolate_upto)[0])
        i = int(gap_at[j])
        allow = ("" if gaps == "refuse" else
                 f", more than interpolate_upto = {interpolate_upto}")
        raise DataError(f"{source} (time)", f"gap of {d[i] - dt_nom:.6g} s "
                        f"({missing[j]} missing samples{allow}) after t = {t[i]:.6g} s; "
                        f"{len(gap_at)} gap(s) in all. Set gaps: split or "
                        f"{{interpolate_upto: N}} to accept them", sample=i + 1)
    if gaps == "interpolate" and gap_at.size:
        # Insert the missing stamps on the nominal clock and bridge the values linearly.
        k = np.concatenate([[0], np.cumsum(np.rint(d / dt_nom).astype(int))])
        full_k = np.arange(k[-1] + 1)
        t = np.interp(full_k, k, t)
        values = np.interp(full_k, k, values)
        gap_at = np.empty(0, dtype=int)
    out, start = [], 0
    for stop in [*(gap_at + 1).tolist(), t.size]:
        a, b = _fit_clock(t[start:stop], f"{source} (time)", start)
        out.append(Piece(values[start:stop], a, b))
        start = stop
    return out


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
        listing = "; ".join(f"{k}: [{round(a, 9):.6g}, {round(b, 9):.6g}] {unit}"
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


def sinc_interpolate(x: np.ndarray, pos: np.ndarray, cutoff: float = 1.0) -> np.ndarray:
    """Band-limited interpolation of ``x`` at fractional sample positions ``pos``.

    A Kaiser-windowed sinc of :data:`HALF_TAPS` taps each side, low-pass at ``cutoff``
    times the Nyquist frequency of ``x`` (``cutoff < 1`` when decimating, so the result
    is anti-aliased), weights renormalised to unit sum so a constant stays exact.
    """
    x = np.asarray(x, dtype=float)
    pos = np.asarray(pos, dtype=float)
    half = int(np.ceil(HALF_TAPS / min(cutoff, 1.0)))
    offs = np.arange(-half + 1, half + 1)
    out = np.empty(pos.size)
    for s in range(0, pos.size, _BLOCK):
        p = pos[s:s + _BLOCK]
        i0 = np.floor(p).astype(np.int64)
        j = i0[:, None] + offs[None, :]
        u = p[:, None] - j
        r = np.clip(1.0 - (u / half) ** 2, 0.0, None)
        w = cutoff * np.sinc(cutoff * u) * np.i0(_KAISER_BETA * np.sqrt(r))
        w[(j < 0) | (j >= x.size)] = 0.0
        out[s:s + _BLOCK] = (w * x[np.clip(j, 0, x.size - 1)]).sum(1) / w.sum(1)
    return out


def resample(piece: Piece, start: float, fs: float, n: int) -> np.ndarray:
    """Values of ``piece`` at ``start + m / fs`` for ``m = 0 … n-1`` (inside the piece).

    Polyphase when ``fs`` and the piece's rate have a rational ratio with terms ≤ 1000,
    then a band-limited fractional delay if the grids are offset; band-limited
    interpolation otherwise. Equal rates on aligned grids give the samples themselves (a
    view of ``piece.values``: no copy of a long record).
    """
    src_fs = 1.0 / piece.dt
    ratio = fs / src_fs
    frac = Fraction(ratio).limit_denominator(1000)
    if abs(float(frac) - ratio) <= 1e-9 * ratio:
        up, down = frac.numerator, frac.denominator
        y = piece.values if up == down == 1 else resample_poly(
            piece.values, up, down, window=("kaiser", _KAISER_BETA), padtype="line")
        pos = (start - piece.t0) * fs + np.arange(n)
        k0 = int(np.rint(pos[0]))
        if abs(pos[0] - k0) < 1e-6 and 0 <= k0 and k0 + n <= y.size:
            return y[k0:k0 + n]
        return sinc_interpolate(y, pos)
    pos = (start + np.arange(n) / fs - piece.t0) * src_fs
    return sinc_interpolate(piece.values, pos, cutoff=min(1.0, ratio))
