"""Angular resampling: a time record to constant shaft angle, and back.

* :class:`AngleMap` -- the shaft angle of every sample of a record, and the positions of a
  constant-angle grid on it (shared by the resampling, TSA and the order spectra);
* :func:`angle_map` -- check a record and its pulse train and build its map;
* :func:`resample_to_angle`, :func:`resample_to_time` -- constant-angle resampling without
  aliasing, and back onto the time samples;
* :func:`spline_coefficients`, :func:`evaluate_spline` -- the cubic B-spline interpolation
  of samples that every resampling here uses;
* :func:`revolution_speed` -- start angle and mean speed of every complete revolution.

Angles and pulses follow :mod:`gbpipe.harmonics.tacho`: rad of the tachometer shaft, 0 at
the first pulse; sample ``i`` of a record sits at ``t0 + i / fs``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import fft as sfft
from scipy import ndimage, signal

from gbpipe.harmonics.checks import as_count, as_positive, as_pulses, as_signal, check_within_record
from gbpipe.harmonics.tacho import AngleMethod, angle_interpolant, check_pulse_times
from gbpipe.units import TWO_PI

__all__ = ["AngleMap", "angle_map", "spline_coefficients", "evaluate_spline",
           "resample_to_angle", "resample_map_to_angle", "resample_to_time",
           "revolution_speed"]

#: Positions per pass of :func:`evaluate_spline` (its temporaries then stay in the cache).
_SPLINE_CHUNK = 16384


@dataclass
class AngleMap:
    """Angle of every sample of a record, and constant-angle grids on it.

    ``theta[j]`` is the angle of sample ``j_lo + j``; the map covers the pulse span plus
    one sample either side (extrapolated), so that grid points between the first pulse
    and the first sample are bracketed. Build it with :meth:`build` (or :func:`angle_map`,
    which also checks the record).

    Attributes
    ----------
    fs, t0, n : float, float, int
        Sample rate [Hz], time of sample 0 [s] and length of the record.
    pulses : numpy.ndarray
        Pulse times [s].
    j_lo : int
        Sample index of ``theta[0]``.
    theta : numpy.ndarray
        Angle [rad] of samples ``j_lo, j_lo + 1, ...``.
    i_lo, i_hi : int
        First and last sample inside the pulse span.
    theta_end : float
        Angle of the last pulse [rad].
    """

    fs: float
    t0: float
    n: int
    pulses: np.ndarray
    j_lo: int
    theta: np.ndarray
    i_lo: int  # first sample inside the pulse span
    i_hi: int  # last sample inside the pulse span
    theta_end: float  # angle of the last pulse

    @property
    def sample_times(self) -> np.ndarray:
        """Times [s] of the samples that ``theta`` covers."""
        return self.t0 + (self.j_lo + np.arange(self.theta.size)) / self.fs

    @classmethod
    def build(cls, n: int, fs: float, p: np.ndarray, ppr: int, method: str,
              t0: float) -> AngleMap:
        """Map of a record of ``n`` samples from checked, increasing pulse times ``p``."""
        i_lo = max(int(np.ceil((p[0] - t0) * fs - 1e-9)), 0)
        i_hi = min(int(np.floor((p[-1] - t0) * fs + 1e-9)), n - 1)
        j_lo, j_hi = max(i_lo - 1, 0), min(i_hi + 1, n - 1)
        f = angle_interpolant(p, ppr, method)
        theta = f(t0 + np.arange(j_lo, j_hi + 1) / fs)
        if np.any(np.diff(theta) <= 0):
            raise ValueError(
                f"the {method!r} angle interpolant is not increasing between some pulses: "
                f"use method='pchip' (monotone) or check pulse_times"
            )
        return cls(fs, t0, n, p, j_lo, theta, i_lo, i_hi, TWO_PI * (p.size - 1) / ppr)

    def grid_positions(self, scale: float, n_grid: int) -> np.ndarray:
        """Fractional sample indices of grid points ``g / scale`` rad, g = 0..n_grid-1.

        The uniform grid is mapped through the sampled angle by linear inverse
        interpolation within each sample interval (the angle is smooth on that scale:
        error ~ alpha dt / (8 omega) samples, < 1e-5 samples here). Built with
        ``np.repeat`` instead of a binary search: O(n + n_grid).
        """
        u = self.theta * scale
        c = np.clip(np.ceil(u), 0, n_grid).astype(np.int64)
        counts = np.diff(c)
        if c[-1] - c[0] != n_grid:
            raise AssertionError("angle grid does not fit in the pulse span")  # pragma: no cover
        # Within interval [i, i+1): pos = i + (g - u_i) / (u_{i+1} - u_i) = g a_i + b_i.
        # np.repeat of a_i, b_i is a sequential fill, ~5x faster than gathering u[seg].
        a = 1.0 / np.diff(u)
        b = (self.j_lo + np.arange(a.size)) - u[:-1] * a
        g = np.arange(c[0], c[-1], dtype=float)
        g *= np.repeat(a, counts)
        g += np.repeat(b, counts)
        return g



def spline_coefficients(x: np.ndarray) -> np.ndarray:
    """Cubic B-spline coefficients of samples ``x`` (mirror boundary), for
    :func:`evaluate_spline`."""
    # Cubic B-spline interpolation of the samples: flat response to ~0.3 fs with O(f^4)
    # error, against sinc^2 (-0.1 dB at 0.06 fs, i.e. only ~-35 dB removal) for linear.
    return ndimage.spline_filter1d(x, order=3, mode="mirror")


def _mirror_index(idx: np.ndarray, n: int) -> np.ndarray:
    """Sample indices folded into ``[0, n - 1]`` about the first and last sample (the
    ``"mirror"`` boundary of :func:`spline_coefficients`)."""
    period = max(2 * (n - 1), 1)
    idx = idx % period
    return np.where(idx > n - 1, period - idx, idx)


def evaluate_spline(coef: np.ndarray, pos: np.ndarray, *,
                    out: np.ndarray | None = None) -> np.ndarray:
    """Cubic B-spline through the samples, at fractional sample positions ``pos``.

    Parameters
    ----------
    coef : numpy.ndarray, shape (n,)
        Coefficients from :func:`spline_coefficients` (mirror boundary).
    pos : numpy.ndarray
        Positions in ``[0, n - 1]`` [samples] (a rounding error beyond either end extends
        the end piece of the spline).
    out : numpy.ndarray, optional
        Contiguous float array of the shape of ``pos`` to write the values into.

    Returns
    -------
    numpy.ndarray
        The spline at ``pos``, of the shape of ``pos`` (``out`` if given).
    """
    # The value of scipy.ndimage.map_coordinates(coef, pos[None], order=3,
    # prefilter=False, mode="mirror") (equal to 2e-15, tests/harmonics/test_angle.py), at
    # twice its speed: the four B-spline weights of each position and a gather of its four
    # coefficients, vectorised over chunks of positions whose temporaries stay in the
    # cache; no memory beyond a chunk's. Written out because scipy's general routines are
    # slow here (400 000 positions on 250 000 samples: map_coordinates 16 ns, an
    # equivalent scipy.interpolate.BSpline 35 ns, this 7 ns per position), and it is the
    # inner loop of every TSA and angle resampling (TSA of a test record: 1.9 s in
    # map_coordinates, 0.7 s here).
    coef = np.asarray(coef, dtype=float)
    pos = np.asarray(pos, dtype=float)
    flat = pos.ravel()
    if out is not None and (out.shape != pos.shape or not out.flags.c_contiguous
                            or out.dtype != float):
        raise ValueError(f"out must be a C-contiguous float array of shape {pos.shape}")
    res = np.empty(pos.shape) if out is None else out
    values = res.reshape(-1)  # a view: res is contiguous
    last = coef.size - 1
    for a in range(0, flat.size, _SPLINE_CHUNK):
        p = flat[a:a + _SPLINE_CHUNK]
        j = np.clip(np.floor(p), 0, last)  # piece [j, j + 1): coefficients j - 1 .. j + 2
        u = p - j
        z = 1.0 - u
        first = j.astype(np.intp) - 1
        taps = [first, first + 1, first + 2, first + 3]
        if first.min() < 0 or first.max() + 3 > last:  # a piece at an end
            taps = [_mirror_index(t, coef.size) for t in taps]
        u2, z2 = u * u, z * z
        acc = coef.take(taps[0])
        acc *= z2 * z
        tap = coef.take(taps[3])
        tap *= u2 * u
        acc += tap
        tap = coef.take(taps[1])
        tap *= u2 * (3.0 * u - 6.0) + 4.0
        acc += tap
        tap = coef.take(taps[2])
        tap *= z2 * (3.0 * z - 6.0) + 4.0
        acc += tap
        np.multiply(acc, 1.0 / 6.0, out=values[a:a + p.size])
    return res


def angle_map(x: np.ndarray, fs: float, pulse_times: np.ndarray, pulses_per_rev: int,
              method: AngleMethod, t0: float) -> tuple[np.ndarray, float, np.ndarray, int,
                                                       AngleMap]:
    """Check a record and its pulse train; build the record's :class:`AngleMap`.

    Returns
    -------
    tuple
        ``(x, fs, pulse_times, pulses_per_rev, amap)``, the arguments as checked arrays
        and numbers.

    Raises
    ------
    DataError
        Bad signal.
    PulseError
        Pulses not increasing or outside the record.
    """
    x = as_signal(x)
    fs = as_positive(fs, "fs", "Hz")
    p = as_pulses(pulse_times)
    ppr = as_count(pulses_per_rev, "pulses_per_rev")
    if np.any(np.diff(p) <= 0):
        check_pulse_times(p)  # raises the explanatory error
    check_within_record(p, float(t0), fs, x.size)
    return x, fs, p, ppr, AngleMap.build(x.size, fs, p, ppr, method, float(t0))


def _default_samples_per_rev(amap: AngleMap) -> int:
    # Angle-domain rate >= fs at the *lowest* speed (where samples per rev are most):
    # then every frequency of the time record is representable and nothing aliases.
    ppr = round(TWO_PI * (amap.pulses.size - 1) / amap.theta_end)
    max_samples_per_rev = float(np.max(np.diff(amap.pulses))) * amap.fs * ppr
    return int(sfft.next_fast_len(int(np.ceil(1.25 * max_samples_per_rev))))


def resample_to_angle(
    x: np.ndarray,
    fs: float,
    pulse_times: np.ndarray,
    *,
    samples_per_rev: int | None = None,
    pulses_per_rev: int = 1,
    t0: float = 0.0,
    method: AngleMethod = "pchip",
) -> tuple[np.ndarray, np.ndarray]:
    """Resample a signal at constant shaft angle, without aliasing.

    The record is first resampled onto an angle grid fine enough that its rate in Hz
    exceeds ``fs`` at the lowest speed (cubic-spline interpolation of the samples, so
    nothing aliases); if ``samples_per_rev`` asks for a coarser grid, the angle-domain
    signal is then low-passed and decimated by a zero-phase polyphase FIR
    (:func:`scipy.signal.resample_poly`): a fixed low-pass in orders, i.e. a low-pass in
    Hz that follows the speed.

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal (any unit), sample ``i`` at ``t0 + i / fs``.
    fs : float
        Sample rate [Hz].
    pulse_times : array_like
        Tachometer pulse times [s], within the record.
    samples_per_rev : int, optional
        Samples per shaft revolution of the output (max order = half of it). Default: the
        alias-free rate, >= 1.25 x the samples per revolution at the lowest speed.
    pulses_per_rev : int
        Pulses per shaft revolution.
    t0 : float
        Time of the first sample [s].
    method : {"pchip", "cubic", "linear"}
        Angle interpolation between pulses.

    Returns
    -------
    theta : numpy.ndarray
        Angles [rad] of the output samples, ``k * 2 pi / samples_per_rev`` from 0 (first
        pulse) to the last pulse.
    x_theta : numpy.ndarray
        Signal at those angles.

    Raises
    ------
    DataError
        Bad signal.
    PulseError
        Pulse times outside the record or not increasing.
    """
    x, fs, p, ppr, amap = angle_map(x, fs, pulse_times, pulses_per_rev, method, t0)
    return resample_map_to_angle(x, amap, samples_per_rev)


def resample_map_to_angle(x: np.ndarray, amap: AngleMap,
                          samples_per_rev: int | None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`resample_to_angle` of a checked record whose :class:`AngleMap` is built.

    Reuse one map for several resamplings of the same record (same pulses). ``x`` of
    shape (n, k) holds k signals of the record (checked ones): they share the angle grid,
    and ``x_theta`` has shape (n_grid, k).
    """
    spr_hi = _default_samples_per_rev(amap)
    q = 1
    if samples_per_rev is not None:
        spr = as_count(samples_per_rev, "samples_per_rev", 4)
        q = max(1, int(np.ceil(spr_hi / spr)))
        spr_hi = spr * q
    n_grid = int(np.floor(amap.theta_end * spr_hi / TWO_PI)) + 1
    pos = amap.grid_positions(spr_hi / TWO_PI, n_grid)
    # one row per signal: the decimation then runs along contiguous rows
    cols = np.atleast_2d(x.T)
    xa = np.empty((cols.shape[0], n_grid))
    for col, row in zip(cols, xa, strict=True):
        evaluate_spline(spline_coefficients(col), pos, out=row)
    if q > 1:
        xa = signal.resample_poly(xa, 1, q, axis=1)
        n_grid = xa.shape[1]
    xa = xa.T if x.ndim == 2 else xa[0]
    spr_out = spr_hi // q
    theta = TWO_PI * np.arange(n_grid) / spr_out
    return theta, xa


def resample_to_time(
    x_theta: np.ndarray,
    samples_per_rev: int,
    n_samples: int,
    fs: float,
    pulse_times: np.ndarray,
    *,
    pulses_per_rev: int = 1,
    t0: float = 0.0,
    method: AngleMethod = "pchip",
    fill: float = np.nan,
) -> np.ndarray:
    """Bring a constant-angle signal back onto time samples.

    Parameters
    ----------
    x_theta : array_like
        Signal at angles ``k * 2 pi / samples_per_rev``, k = 0, 1, ... (0 = first pulse),
        as returned by :func:`resample_to_angle`.
    samples_per_rev : int
        Samples per revolution of ``x_theta``.
    n_samples : int
        Length of the time record.
    fs : float
        Sample rate of the time record [Hz].
    pulse_times, pulses_per_rev, t0, method
        As in :func:`resample_to_angle`.
    fill : float
        Value for samples outside the angle span of ``x_theta``.

    Returns
    -------
    numpy.ndarray, shape (n_samples,)
        Cubic-spline interpolation of ``x_theta`` at each sample's angle.
    """
    xa = as_signal(x_theta, "x_theta")
    spr = as_count(samples_per_rev, "samples_per_rev", 4)
    n = as_count(n_samples, "n_samples", 2)
    fs = as_positive(fs, "fs", "Hz")
    p = as_pulses(pulse_times)
    ppr = as_count(pulses_per_rev, "pulses_per_rev")
    check_within_record(p, float(t0), fs, n)
    amap = AngleMap.build(n, fs, p, ppr, method, float(t0))
    out = np.full(n, fill, dtype=float)
    sel = slice(amap.i_lo - amap.j_lo, amap.i_hi - amap.j_lo + 1)
    pos = amap.theta[sel] * spr / TWO_PI
    inside = pos <= xa.size - 1
    vals = evaluate_spline(spline_coefficients(xa), pos[inside])
    idx = np.arange(amap.i_lo, amap.i_hi + 1)[inside]
    out[idx] = vals
    return out


def revolution_speed(amap: AngleMap) -> tuple[np.ndarray, np.ndarray]:
    """Start angle [rad] and mean speed [rev/min] of every complete revolution of a map."""
    n_rev = int(np.floor(amap.theta_end / TWO_PI + 1e-9))
    th = TWO_PI * np.arange(n_rev + 1)
    t_rev = np.interp(th, amap.theta, amap.sample_times)
    return th[:-1], 60.0 / np.diff(t_rev)
