"""Argument checks shared by every harmonic-removal module.

Bad *data* (a signal with NaN, a pulse train that is not usable) raises
:class:`gbpipe.errors.DataError` or :class:`gbpipe.errors.PulseError`, with the index of
the first offending sample; bad *arguments* (a negative sample rate, a non-integer count)
raise :class:`ValueError` / :class:`TypeError`. Both ``DataError`` and ``PulseError``
are ``ValueError`` subclasses.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from scipy import signal

from gbpipe.errors import DataError, PulseError

__all__ = ["as_signal", "as_positive", "as_count", "as_order", "as_pulses",
           "check_within_record", "check_overlap", "get_window"]


def as_signal(x: object, name: str = "x") -> np.ndarray:
    """A 1-D float array of at least 2 finite samples.

    Raises
    ------
    DataError
        Wrong shape, too short, or NaN/inf samples (``sample`` = the first of them).
    """
    arr = np.asarray(x, dtype=float)
    if arr.ndim != 1:
        raise DataError(name, f"must be a 1-D array of samples; got shape {arr.shape}: "
                        f"pass one channel at a time (e.g. {name}[:, 0])")
    if arr.size < 2:
        raise DataError(name, f"needs at least 2 samples; got {arr.size}")
    bad = ~np.isfinite(arr)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise DataError(
            name, f"contains {int(bad.sum())} NaN/inf samples (first at index {first}): fill "
            f"the gaps (e.g. interpolate) or cut the record to a finite stretch first",
            sample=first)
    return arr


def as_positive(value: object, name: str, unit: str) -> float:
    """A finite float > 0 (``unit`` is only used in the message)."""
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a real number in {unit}; got {value!r}") from None
    if not np.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be a finite number > 0 in {unit}; got {value!r}")
    return v


def as_count(value: object, name: str, minimum: int = 1) -> int:
    """An integer ``>= minimum`` (bool refused)."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an integer >= {minimum}; got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}; got {value}")
    return int(value)


def as_order(value: object, name: str = "cycle_order") -> float:
    """An order of the tachometer shaft: float, int or :class:`fractions.Fraction` > 0."""
    if isinstance(value, bool):
        raise TypeError(f"{name} must be a float or fractions.Fraction; got {value!r}")
    if isinstance(value, Fraction):
        v = float(value)
    else:
        try:
            v = float(value)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be a float or fractions.Fraction in orders of the "
                            f"tachometer shaft; got {value!r}") from None
    if not np.isfinite(v) or v <= 0:
        raise ValueError(
            f"{name} must be > 0 (a frequency in orders of the tachometer shaft, e.g. 1 for "
            f"the HSS, or the kinematic ratio of a shaft or mesh); got {value!r}"
        )
    return v


def as_pulses(pulse_times: object, name: str = "pulse_times") -> np.ndarray:
    """A 1-D float array of at least 3 finite pulse times [s] (order not checked).

    Raises
    ------
    PulseError
        Wrong shape, fewer than 3 pulses, or NaN/inf (``sample`` = the first of them).
    """
    p = np.asarray(pulse_times, dtype=float)
    if p.ndim != 1:
        raise PulseError(name, f"must be a 1-D array of times in s; got shape {p.shape}")
    if p.size < 3:
        raise PulseError(name, f"needs at least 3 pulses to define a shaft angle; got "
                         f"{p.size}: use a longer record or more pulses per revolution")
    bad = ~np.isfinite(p)
    if bad.any():
        raise PulseError(name, "contains NaN/inf: drop those entries before calling",
                         sample=int(np.flatnonzero(bad)[0]))
    return p


def check_within_record(p: np.ndarray, t0: float, fs: float, n: int) -> None:
    """Refuse pulse times outside ``[t0, t0 + (n - 1) / fs]`` (the record's samples).

    Raises
    ------
    PulseError
        With ``sample`` = index of the first pulse outside the record.
    """
    t_end = t0 + (n - 1) / fs
    outside = (p < t0) | (p > t_end)
    if outside.any():
        raise PulseError(
            "pulse_times",
            f"span [{p[0]:.6g}, {p[-1]:.6g}] s but the record covers [{t0:.6g}, {t_end:.6g}] "
            f"s: keep only pulses inside the record, pulse_times[(pulse_times >= t0) & "
            f"(pulse_times <= t_end)], or pass the record's start time as t0",
            sample=int(np.flatnonzero(outside)[0]))


def check_overlap(overlap: float) -> float:
    """A frame overlap fraction in [0, 1)."""
    if not 0.0 <= overlap < 1.0:
        raise ValueError(f"overlap must be in [0, 1) (fraction of a frame); got {overlap}")
    return float(overlap)


def get_window(name: str | tuple, n: int) -> np.ndarray:
    """Periodic (DFT-even) :func:`scipy.signal.get_window` window, with a clear error."""
    try:
        return signal.get_window(name, n, fftbins=True)
    except ValueError as err:
        raise ValueError(f"window {name!r} is not a scipy.signal window: {err}") from None
