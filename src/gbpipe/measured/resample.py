"""Anti-aliased resampling of a uniformly sampled piece onto the record's grid, in one go
(:func:`resample`) or block by block with the same values (:class:`BlockResampler`).

Never nearest-sample: when the two rates have a small rational ratio ``up/down`` the
signal goes through :func:`scipy.signal.resample_poly` (a polyphase FIR with its own
anti-aliasing low-pass, here a Kaiser window of β = 8.6: -80 dB stop band, gain flat to
1e-5 up to 0.6 of the output Nyquist frequency, 1e-2 at 0.8) and, if the grids are offset
by a fraction of a sample, through a band-limited (Kaiser-windowed sinc) fractional delay;
otherwise the windowed-sinc interpolator is used directly, with its cut-off lowered to the
lower of the two Nyquist frequencies. The first and last :data:`HALF_TAPS` samples of a
piece are within one filter length of its edge and carry the usual edge transient.

Both filters are local (finite impulse responses), so a block of output needs only the
input samples under the filter: :class:`BlockResampler` reads those (plus the filter's
half-length of context each side), and reproduces the one-shot result to rounding — at
the piece's ends too, where it extends the input by the same straight line as
``resample_poly(..., padtype="line")`` (through the piece's first and last samples).
"""

from __future__ import annotations

from collections.abc import Callable
from fractions import Fraction
from typing import Protocol

import numpy as np
from scipy.signal import resample_poly

__all__ = ["resample", "sinc_interpolate", "BlockResampler", "rational_ratio", "HALF_TAPS"]

#: half length of the windowed-sinc kernel [samples]
HALF_TAPS = 16
_KAISER_BETA = 8.6  # -80 dB side lobes
_WINDOW = ("kaiser", _KAISER_BETA)
# weights computed at a time by sinc_interpolate (rows x taps): bounded memory whatever
# the cut-off (a low cut-off widens the kernel)
_WEIGHTS = (1 << 16) * 2 * HALF_TAPS


class UniformPiece(Protocol):
    """What :func:`resample` needs of a piece: samples, first time, interval."""

    values: np.ndarray
    t0: float
    dt: float


def rational_ratio(ratio: float) -> tuple[int, int] | None:
    """``(up, down)`` when ``ratio`` is a rational number with terms ≤ 1000 (to 1e-9
    relative), else ``None``."""
    frac = Fraction(ratio).limit_denominator(1000)
    if abs(float(frac) - ratio) <= 1e-9 * ratio:
        return frac.numerator, frac.denominator
    return None


def sinc_interpolate(x: np.ndarray, pos: np.ndarray, cutoff: float = 1.0, *, first: int = 0,
                     total: int | None = None) -> np.ndarray:
    """Band-limited interpolation of ``x`` at fractional sample positions ``pos``.

    A Kaiser-windowed sinc of :data:`HALF_TAPS` taps each side, low-pass at ``cutoff``
    times the Nyquist frequency of ``x`` (``cutoff < 1`` when decimating, so the result
    is anti-aliased), weights renormalised to unit sum so a constant stays exact.

    Parameters
    ----------
    x : numpy.ndarray
        Samples ``first … first + x.size - 1`` of a signal of ``total`` samples (by
        default ``x`` is the whole signal). It must cover the kernel around every
        position; samples outside ``0 … total-1`` get weight 0.
    pos : numpy.ndarray
        Positions [samples of the whole signal].
    """
    x = np.asarray(x, dtype=float)
    pos = np.asarray(pos, dtype=float)
    total = x.size + first if total is None else total
    half = int(np.ceil(HALF_TAPS / min(cutoff, 1.0)))
    offs = np.arange(-half + 1, half + 1)
    rows = max(256, _WEIGHTS // offs.size)
    out = np.empty(pos.size)
    for s in range(0, pos.size, rows):
        p = pos[s:s + rows]
        i0 = np.floor(p).astype(np.int64)
        j = i0[:, None] + offs[None, :]
        u = p[:, None] - j
        r = np.clip(1.0 - (u / half) ** 2, 0.0, None)
        w = cutoff * np.sinc(cutoff * u) * np.i0(_KAISER_BETA * np.sqrt(r))
        w[(j < 0) | (j >= total)] = 0.0
        out[s:s + rows] = (w * x[np.clip(j - first, 0, x.size - 1)]).sum(1) / w.sum(1)
    return out


def resample(piece: UniformPiece, start: float, fs: float, n: int) -> np.ndarray:
    """Values of ``piece`` at ``start + m / fs`` for ``m = 0 … n-1`` (inside the piece).

    Polyphase when ``fs`` and the piece's rate have a rational ratio with terms ≤ 1000,
    then a band-limited fractional delay if the grids are offset; band-limited
    interpolation otherwise. Equal rates on aligned grids give the samples themselves (a
    view of ``piece.values``: no copy of a long record).
    """
    src_fs = 1.0 / piece.dt
    ratio = fs / src_fs
    r = rational_ratio(ratio)
    if r is not None:
        up, down = r
        y = piece.values if up == down == 1 else resample_poly(
            piece.values, up, down, window=_WINDOW, padtype="line")
        pos = (start - piece.t0) * fs + np.arange(n)
        k0 = int(np.rint(pos[0]))
        if abs(pos[0] - k0) < 1e-6 and 0 <= k0 and k0 + n <= y.size:
            return y[k0:k0 + n]
        return sinc_interpolate(y, pos)
    pos = (start + np.arange(n) / fs - piece.t0) * src_fs
    return sinc_interpolate(piece.values, pos, cutoff=min(1.0, ratio))


def _span(pos: np.ndarray, half: int, total: int) -> tuple[int, int]:
    """Samples ``[lo, hi)`` under a ``half``-tap kernel at positions ``pos`` (sorted)."""
    lo = int(np.floor(pos[0])) - half + 1
    hi = int(np.floor(pos[-1])) + half + 1
    return max(lo, 0), min(hi, total)


class BlockResampler:
    """:func:`resample` of a piece that is read block by block.

    ``BlockResampler(read, size, t0, dt, start, fs, n)(a, b)`` equals
    ``resample(piece, start, fs, n)[a:b]`` to rounding, reading only the samples the
    filters need.

    Parameters
    ----------
    read : callable
        ``read(i, j)`` returns samples ``i … j-1`` of the piece (a new array).
    size : int
        Samples in the piece.
    t0, dt : float
        Time of its first sample and sample interval [s].
    start, fs, n
        As for :func:`resample`: first grid time [s], grid rate [Hz], grid length.
    """

    def __init__(self, read: Callable[[int, int], np.ndarray], size: int, t0: float,
                 dt: float, start: float, fs: float, n: int) -> None:
        self.read, self.size, self.t0, self.start, self.fs = read, size, t0, start, fs
        self.src_fs = 1.0 / dt
        self.ratio = fs / self.src_fs
        self.updown = rational_ratio(self.ratio)
        self.aligned = None
        if self.updown is None:
            return
        up, down = self.updown
        self.ny = size if up == down == 1 else size * up // down + bool(size * up % down)
        pos0 = (start - t0) * fs
        k0 = int(np.rint(pos0))
        if abs(pos0 - k0) < 1e-6 and 0 <= k0 and k0 + n <= self.ny:
            self.aligned = k0
        if up == down == 1:
            return
        ends = np.concatenate([read(0, 1), read(size - 1, size)])
        # resample_poly's padtype="line": the straight line through the first and last
        # samples continues the piece beyond both ends
        self.line = (ends[0], ends[1], (ends[1] - ends[0]) / (size - 1) if size > 1 else 0.0)
        # input context of the polyphase filter (10 max(up, down) taps at the up-sampled
        # rate), rounded up to whole multiples of down so the output phases stay aligned
        self.margin = down * (-(-10 * max(up, down) // (up * down)) + 2)

    def __call__(self, a: int, b: int) -> np.ndarray:
        """Grid samples ``a … b-1``."""
        m = np.arange(a, b)
        if self.updown is None:
            pos = (self.start + m / self.fs - self.t0) * self.src_fs
            cutoff = min(1.0, self.ratio)
            lo, hi = _span(pos, int(np.ceil(HALF_TAPS / cutoff)), self.size)
            return sinc_interpolate(self.read(lo, hi), pos, cutoff=cutoff, first=lo,
                                    total=self.size)
        if self.aligned is not None:
            return self._poly(self.aligned + a, self.aligned + b)
        pos = (self.start - self.t0) * self.fs + m
        lo, hi = _span(pos, HALF_TAPS, self.ny)
        return sinc_interpolate(self._poly(lo, hi), pos, first=lo, total=self.ny)

    def _poly(self, j0: int, j1: int) -> np.ndarray:
        """Samples ``j0 … j1-1`` of ``resample_poly(values, up, down, padtype="line")``."""
        up, down = self.updown
        if up == down == 1:
            return self.read(j0, j1)
        s0 = (j0 * down // up) // down * down - self.margin
        s1 = -(-(j1 - 1) * down // up) + self.margin + 1
        parts = []
        first, last, slope = self.line
        if s0 < 0:
            parts.append(first + slope * np.arange(s0, 0))
        parts.append(self.read(max(s0, 0), min(s1, self.size)))
        if s1 > self.size:
            parts.append(last + slope * np.arange(1, s1 - self.size + 1))
        y = resample_poly(np.concatenate(parts), up, down, window=_WINDOW, padtype="constant")
        off = s0 * up // down
        return y[j0 - off:j1 - off]
