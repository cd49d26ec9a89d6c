"""Tachometer pulses: from an analog channel to pulse times, pulse-train checks and
repair, and the shaft angle and speed they define.

* :func:`pulse_times_from_tacho` -- pulse times from a sampled analog tachometer channel
  (Schmitt trigger with hysteresis, sub-sample timing of each edge);
* :func:`check_pulse_times` -- sanity checks on a pulse train (increasing times, missing or
  extra pulses from interval ratios, jitter); repairs only on request, with a warning;
* :func:`angle_interpolant` -- the piecewise cubic angle(t) through the pulses;
* :func:`shaft_angle`, :func:`shaft_speed` -- shaft angle [rad] and speed [rad/s] vs time.

Angles are in rad of the shaft carrying the tachometer (the HSS in gbpipe), zero at the
first pulse: pulse ``k`` sits at ``2 pi k / pulses_per_rev``. Orders are multiples of that
shaft's speed (docs/architecture.md, "Physics").

Why PCHIP by default. Between pulses the angle must be interpolated. Linear interpolation
means piecewise-constant speed: on a run-up the angle error between pulses is
``alpha dt^2 / 8`` (alpha the angular acceleration, dt the pulse interval), and every order
``m`` sees ``m`` times that as phase error, so high orders smear. A cubic through the pulse
angles is O(dt^4) accurate on a smooth speed profile. PCHIP is a cubic that preserves
monotonicity, so the angle never runs backwards (required for inverting it) even on a
rough pulse train, where a not-a-knot spline ("cubic") can overshoot. On the smooth
synthetic sweeps of the tests the two give the same removal (see docs/harmonics.md).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import interpolate, ndimage

from gbpipe.errors import PulseError
from gbpipe.harmonics.checks import as_count, as_positive, as_pulses, as_signal
from gbpipe.units import TWO_PI

__all__ = ["AngleMethod", "ANGLE_METHODS", "PulseCheck", "pulse_times_from_tacho",
           "check_pulse_times", "angle_interpolant", "shaft_angle", "shaft_speed"]

#: Interpolation of the shaft angle between pulses (see the module notes).
AngleMethod = Literal["pchip", "cubic", "linear"]
ANGLE_METHODS = ("pchip", "cubic", "linear")

def pulse_times_from_tacho(
    tacho: np.ndarray,
    fs: float,
    *,
    threshold: float | None = None,
    hysteresis: float | None = None,
    edge: Literal["rising", "falling"] = "rising",
    t0: float = 0.0,
) -> np.ndarray:
    """Pulse times from a sampled analog tachometer channel.

    A Schmitt trigger arms below ``threshold - hysteresis/2`` and fires above
    ``threshold + hysteresis/2``; each firing is timed at the crossing of ``threshold``
    itself, by linear interpolation between the two samples that straddle it (sub-sample
    timing). The hysteresis keeps noise on a slow edge from producing double pulses.

    Parameters
    ----------
    tacho : array_like, shape (n,)
        Tachometer voltage (any unit).
    fs : float
        Sample rate [Hz].
    threshold : float, optional
        Trigger level [unit of ``tacho``]. Default: midway between the 1st and 99th
        percentiles of ``tacho``.
    hysteresis : float, optional
        Full width of the hysteresis band [unit of ``tacho``]. Default: 20 % of the
        1st-99th percentile span.
    edge : {"rising", "falling"}
        Which edge makes a pulse.
    t0 : float
        Time of the first sample [s].

    Returns
    -------
    numpy.ndarray
        Pulse times [s], increasing.

    Raises
    ------
    DataError
        On a non-1-D or non-finite ``tacho``.
    ValueError
        On ``fs <= 0``, a negative hysteresis, or a
        threshold band outside the signal range.
    """
    v = as_signal(tacho, "tacho")
    fs = as_positive(fs, "fs", "Hz")
    if edge not in ("rising", "falling"):
        raise ValueError(f"edge must be 'rising' or 'falling'; got {edge!r}")
    lo_p, hi_p = np.percentile(v, [1.0, 99.0])
    span = hi_p - lo_p
    if threshold is None:
        threshold = 0.5 * (lo_p + hi_p)
    if hysteresis is None:
        hysteresis = 0.2 * span
    if hysteresis < 0:
        raise ValueError(f"hysteresis must be >= 0 (full band width); got {hysteresis}")
    if edge == "falling":
        # A falling edge of v is a rising edge of -v.
        v, threshold = -v, -threshold
    lo, hi = threshold - 0.5 * hysteresis, threshold + 0.5 * hysteresis
    if not (v.min() < lo and v.max() > hi):
        raise ValueError(
            f"threshold={threshold:g} with hysteresis={hysteresis:g} lies outside the range "
            f"of tacho [{v.min():g}, {v.max():g}]: lower the hysteresis or move the threshold"
        )
    # Trigger state without a Python loop: the state at sample i is set by the last sample
    # <= i that was outside the band (above -> 1, below -> 0).
    n = v.size
    idx = np.arange(n)
    outside = (v > hi) | (v < lo)
    last_out = np.maximum.accumulate(np.where(outside, idx, -1))
    state = np.where(last_out >= 0, v[np.maximum(last_out, 0)] > hi, False)
    fire = np.flatnonzero(state[1:] & ~state[:-1]) + 1
    # Drop a "fire" that is really the initial state being high (no arming before it).
    armed_before = np.maximum.accumulate(np.where(v < lo, idx, -1))
    fire = fire[armed_before[fire - 1] >= 0]
    # Crossing of the threshold itself: last sample <= threshold before the firing sample.
    last_le = np.maximum.accumulate(np.where(v <= threshold, idx, -1))
    j = last_le[fire]
    j = j[(j >= 0) & (j < n - 1)]
    frac = (threshold - v[j]) / (v[j + 1] - v[j])
    return t0 + (j + frac) / fs


@dataclass(frozen=True)
class PulseCheck:
    """Result of :func:`check_pulse_times`.

    Attributes
    ----------
    pulse_times : numpy.ndarray
        The (possibly repaired) pulse times [s].
    missing_after : numpy.ndarray
        Indices (into the input) of pulses followed by a gap with missing pulses.
    n_missing : numpy.ndarray
        Number of missing pulses in each of those gaps.
    extra : numpy.ndarray
        Indices (into the input) of pulses judged extra.
    ratio : numpy.ndarray
        Each interval divided by the local median interval (input pulse train).
    """

    pulse_times: np.ndarray
    missing_after: np.ndarray
    n_missing: np.ndarray
    extra: np.ndarray
    ratio: np.ndarray


def check_pulse_times(
    pulse_times: np.ndarray,
    *,
    tolerance: float = 0.25,
    repair: bool = False,
    window: int = 9,
) -> PulseCheck:
    """Check a tachometer pulse train; optionally repair missing and extra pulses.

    Each interval is divided by the running median of the intervals around it
    (``window`` intervals, robust to isolated faults). A ratio within ``1 +- tolerance``
    is normal; a ratio near an integer ``m >= 2`` (within ``m * tolerance``) is a gap with
    ``m - 1`` missing pulses; two consecutive short intervals adding up to one normal
    interval hide an extra pulse; anything else is jitter.

    Parameters
    ----------
    pulse_times : array_like
        Pulse times [s].
    tolerance : float
        Allowed relative deviation of an interval from the local median [-]. Must exceed
        the interval change from real acceleration over ``window`` intervals and any
        tooth-spacing error of the tachometer wheel.
    repair : bool
        If True, insert missing pulses (cubic spline of time vs pulse number through the
        kept pulses, so they follow the acceleration) and delete extra ones, with a
        :class:`UserWarning`; jitter is never repaired.
    window : int
        Odd number of intervals of the running median.

    Returns
    -------
    PulseCheck
        Repaired (or unchanged) pulse times and what was found.

    Raises
    ------
    PulseError
        Pulse times not strictly increasing; missing or extra pulses with
        ``repair=False``; jittery intervals (``sample`` = the first offending pulse).
    """
    p = as_pulses(pulse_times)
    if not 0 < tolerance < 0.5:
        raise ValueError(f"tolerance must be in (0, 0.5) (relative interval deviation); "
                         f"got {tolerance}")
    window = as_count(window, "window", 3)
    dt = np.diff(p)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        i = int(bad[0])
        raise PulseError(
            "pulse_times",
            f"must be strictly increasing; {bad.size} non-increasing step(s), first at index "
            f"{i + 1} (t={p[i + 1]:.6g} s after {p[i]:.6g} s): sort them and drop duplicates "
            f"(numpy.unique), or re-detect the pulses", sample=i + 1)
    ref = ndimage.median_filter(dt, size=window | 1, mode="nearest")
    r = dt / ref
    normal = np.abs(r - 1.0) <= tolerance
    m = np.rint(r)
    gap = (m >= 2) & (np.abs(r - m) <= tolerance * m)
    # An extra pulse splits one interval into two short ones summing to a normal one.
    # Each short interval pairs with the neighbour that brings the sum closest to 1;
    # the pulse they share is the extra one.
    short = (r < 1 - tolerance) & ~gap
    s_left = np.full(r.size, np.inf)
    s_right = np.full(r.size, np.inf)
    s_left[1:] = np.abs(r[:-1] + r[1:] - 1.0)
    s_right[:-1] = np.abs(r[:-1] + r[1:] - 1.0)
    use_right = s_right <= s_left
    best = np.where(use_right, s_right, s_left)
    paired = short & (best <= tolerance)
    iv = np.flatnonzero(paired)
    extra = np.unique(np.where(use_right[iv], iv + 1, iv))  # shared pulse index
    extra_iv = np.zeros_like(normal)
    extra_iv[extra - 1] = True
    extra_iv[extra] = True
    jitter = ~(normal | gap | extra_iv)
    if jitter.any():
        i = int(np.flatnonzero(jitter)[0])
        raise PulseError(
            "pulse_times",
            f"jittery: {int(jitter.sum())} interval(s) deviate from the local "
            f"median interval by more than tolerance={tolerance} and are neither missing nor "
            f"extra pulses (first at index {i}, t={p[i]:.6g} s, ratio {r[i]:.3f}): check the "
            f"tachometer threshold and hysteresis (pulse_times_from_tacho) or smooth the pulse "
            f"times; raise tolerance only if the speed truly changes that fast", sample=i)
    gaps = np.flatnonzero(gap)
    n_missing = (m[gaps] - 1).astype(int)
    if (gaps.size or extra.size) and not repair:
        what = []
        first = int(min(gaps[:1].tolist() + extra[:1].tolist()))
        if gaps.size:
            i = int(gaps[0])
            what.append(f"{int(n_missing.sum())} missing pulse(s) (first gap after index {i}, "
                        f"t={p[i]:.6g} s, interval {r[i]:.2f}x the local median)")
        if extra.size:
            i = int(extra[0])
            what.append(f"{extra.size} extra pulse(s) (first at index {i}, t={p[i]:.6g} s)")
        raise PulseError(
            "pulse_times",
            "has " + " and ".join(what) + ": fix the tachometer detection, or call "
            "gbpipe.harmonics.check_pulse_times(pulse_times, repair=True) to insert/delete "
            "them (a warning is issued) and pass its .pulse_times", sample=first)
    out = p
    if gaps.size or extra.size:
        # Pulse number of every kept pulse (gaps skip numbers), then missing pulses by a
        # cubic spline of time vs pulse number: follows the acceleration, unlike equal
        # spacing (PCHIP if the spline is not increasing, e.g. on a rough train).
        keep = np.ones(p.size, bool)
        keep[extra] = False
        step = np.where(gap, m, 1.0).astype(np.int64)
        number = np.concatenate([[0], np.cumsum(step)])
        number_kept = number[keep]
        # Deleting an extra pulse merges two intervals worth one pulse step in total.
        number_kept = number_kept - np.searchsorted(extra, np.flatnonzero(keep), side="left")
        t_kept = p[keep]
        all_numbers = np.arange(number_kept[-1] + 1)
        out = interpolate.CubicSpline(number_kept, t_kept)(all_numbers)
        if np.any(np.diff(out) <= 0):
            out = interpolate.PchipInterpolator(number_kept, t_kept)(all_numbers)
        out[np.searchsorted(all_numbers, number_kept)] = t_kept  # kept pulses exactly
        warnings.warn(
            f"check_pulse_times: repaired pulse train, inserted {int(n_missing.sum())} missing "
            f"and deleted {extra.size} extra pulse(s)",
            UserWarning,
            stacklevel=2,
        )
    return PulseCheck(out, gaps, n_missing, extra, r)


def angle_interpolant(p: np.ndarray, pulses_per_rev: int, method: str) -> interpolate.PPoly:
    """Shaft angle [rad] vs time [s] through the pulse angles ``2 pi k / pulses_per_rev``.

    A :class:`scipy.interpolate.PPoly` (extrapolating); ``method`` is one of
    :data:`ANGLE_METHODS` (module notes). ``p`` must be strictly increasing.
    """
    if method not in ANGLE_METHODS:
        raise ValueError(f"method must be one of {ANGLE_METHODS}; got {method!r}")
    theta = TWO_PI * np.arange(p.size) / pulses_per_rev
    if method == "pchip":
        return interpolate.PchipInterpolator(p, theta, extrapolate=True)
    if method == "cubic":
        return interpolate.CubicSpline(p, theta, bc_type="not-a-knot", extrapolate=True)
    return interpolate.PPoly.from_spline(interpolate.make_interp_spline(p, theta, k=1))


def _angle_or_speed(t: np.ndarray, pulse_times: np.ndarray, pulses_per_rev: int,
                    method: AngleMethod, derivative: int) -> np.ndarray:
    # one evaluation of the angle interpolant (or its derivative), NaN outside the pulses
    p = as_pulses(pulse_times)
    ppr = as_count(pulses_per_rev, "pulses_per_rev")
    t = np.asarray(t, dtype=float)
    out = angle_interpolant(p, ppr, method).derivative(derivative)(t)
    out[(t < p[0]) | (t > p[-1])] = np.nan
    return out


def shaft_angle(t: np.ndarray, pulse_times: np.ndarray, *, pulses_per_rev: int = 1,
                method: AngleMethod = "pchip") -> np.ndarray:
    """Shaft angle at times ``t`` from the pulse times.

    Parameters
    ----------
    t : array_like
        Times [s].
    pulse_times : array_like
        Strictly increasing pulse times [s].
    pulses_per_rev : int
        Pulses per shaft revolution (equally spaced).
    method : {"pchip", "cubic", "linear"}
        Interpolation of angle vs time between pulses (see module notes).

    Returns
    -------
    numpy.ndarray
        Angle [rad], 0 at the first pulse; NaN outside the pulse span.
    """
    return _angle_or_speed(t, pulse_times, pulses_per_rev, method, derivative=0)


def shaft_speed(t: np.ndarray, pulse_times: np.ndarray, *, pulses_per_rev: int = 1,
                method: AngleMethod = "pchip") -> np.ndarray:
    """Shaft speed at times ``t``: derivative of :func:`shaft_angle`.

    Parameters
    ----------
    t, pulse_times, pulses_per_rev, method
        As in :func:`shaft_angle`.

    Returns
    -------
    numpy.ndarray
        Speed [rad/s]; NaN outside the pulse span. Multiply by ``60 / (2 pi)`` for rpm.
    """
    return _angle_or_speed(t, pulse_times, pulses_per_rev, method, derivative=1)

