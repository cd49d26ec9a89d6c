"""Order lines are not modes: which identified poles sit on a shaft-order line.

An angle-locked excitation (shaft unbalance, misalignment, a mesh) puts a line at
``order x shaft frequency`` into every spectrum of the record. A subspace or LSCF fit
explains that line with a lightly damped pole, which is stable across model orders just
as a structural mode is. What tells them apart is the shaft speed: over the record the
speed spans ``[f_low, f_high]`` (from the tachometer pulse train), so order ``k`` covers
``[k f_low, k f_high]``, widened on each side by the frequency resolution of the data
(the line cannot be located better than that). A pole inside such a band is labelled
``harmonic``; any other pole is a ``mode``.

The candidate orders are the shaft orders ``1 .. n_harmonics`` of the tacho shaft
(unbalance and misalignment are always there) plus the orders the user lists for the
record (``measured.<record>.orders``) or the excitation families a simulated record was
built with. A mode that happens to lie inside a band is reported as ``harmonic``: the data
of one speed range cannot separate the two, and the label says so rather than claiming a
mode (docs/modal.md, "Criteria").
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import xarray as xr

from gbpipe.errors import ConfigError, DataError
from gbpipe.harmonics import check_pulse_times

__all__ = ["HarmonicBands", "shaft_frequency_range", "harmonic_bands", "record_harmonic_bands",
           "label_poles", "KINDS"]

#: The labels of a pole or cluster.
KINDS = ("mode", "harmonic")


class HarmonicBands(NamedTuple):
    """Frequency bands of the order lines of one record.

    Attributes
    ----------
    order : ndarray, shape (B,)
        Shaft order of each band [-] (multiples of the tacho shaft frequency).
    low_hz, high_hz : ndarray, shape (B,)
        Band edges [Hz]: order x the slowest / fastest shaft frequency, minus / plus the
        frequency resolution.
    shaft_hz : tuple of float
        The tacho shaft's frequency range over the record ``(f_low, f_high)`` [Hz]; NaN
        without a tachometer.
    """

    order: np.ndarray
    low_hz: np.ndarray
    high_hz: np.ndarray
    shaft_hz: tuple[float, float]


def shaft_frequency_range(pulse_time: np.ndarray, pulses_per_rev: int) -> tuple[float, float]:
    """Slowest and fastest shaft rotation frequency of a pulse train [Hz].

    Each frequency is one full revolution (``pulses_per_rev`` intervals) over its
    duration: averaging over a revolution cancels the tooth-spacing error of the wheel,
    which would otherwise widen the range by the spacing error of one tooth.

    Parameters
    ----------
    pulse_time : ndarray, shape (P,)
        Strictly increasing pulse times [s].
    pulses_per_rev : int
        Pulses per revolution of the tacho shaft, >= 1.

    Returns
    -------
    (float, float)
        ``(f_low, f_high)`` [Hz].

    Raises
    ------
    gbpipe.errors.PulseError
        Non-increasing, missing or extra pulses (:func:`gbpipe.harmonics.check_pulse_times`),
        or fewer than two revolutions of pulses.
    """
    p = check_pulse_times(pulse_time).pulse_times
    ppr = int(pulses_per_rev)
    if ppr < 1:
        raise ConfigError("pulses_per_rev", f"must be >= 1; got {pulses_per_rev}")
    if p.size < 2 * ppr + 1:
        raise DataError("pulse_time", f"{p.size} pulses are fewer than two revolutions at "
                        f"{ppr} pulses per revolution: record a longer run")
    f_rev = 1.0 / (p[ppr:] - p[:-ppr])
    return float(f_rev.min()), float(f_rev.max())


def harmonic_bands(shaft_hz: tuple[float, float], orders: Sequence[float], resolution_hz: float,
                   n_harmonics: int, f_max: float | None = None) -> HarmonicBands:
    """The bands of the shaft orders ``1 .. n_harmonics`` and of ``orders``.

    Parameters
    ----------
    shaft_hz : (float, float)
        Slowest and fastest shaft frequency of the record [Hz] (:func:`shaft_frequency_range`).
    orders : sequence of float
        Further orders of the tacho shaft (gear meshes, other shafts referred to it) [-], > 0.
    resolution_hz : float
        Frequency resolution of the data [Hz] (Welch: ``1 / segment``), > 0.
    n_harmonics : int
        Integer shaft orders always taken as candidates, >= 0.
    f_max : float, optional
        Bands starting above this frequency [Hz] are dropped.

    Returns
    -------
    HarmonicBands
        Sorted by order, each order once.

    Raises
    ------
    gbpipe.errors.ConfigError
        A non-positive or non-finite order, resolution or shaft frequency.
    """
    lo, hi = (float(v) for v in shaft_hz)
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo <= hi):
        raise ConfigError("shaft_hz", f"must be 0 < f_low <= f_high [Hz]; got {shaft_hz}")
    if not (np.isfinite(resolution_hz) and resolution_hz > 0):
        raise ConfigError("identify.nonparametric.segment", f"the frequency resolution "
                          f"{resolution_hz} Hz must be positive and finite")
    k = np.asarray(list(orders), dtype=float)
    if k.size and not np.all(np.isfinite(k) & (k > 0)):
        raise ConfigError("orders", f"shaft orders must be positive numbers; got {k.tolist()}")
    k = np.unique(np.concatenate([np.arange(1.0, int(n_harmonics) + 1), k]))
    low, high = k * lo - resolution_hz, k * hi + resolution_hz
    if f_max is not None:
        keep = low <= f_max
        k, low, high = k[keep], low[keep], high[keep]
    return HarmonicBands(k, np.maximum(low, 0.0), high, (lo, hi))


def record_harmonic_bands(record: xr.Dataset, orders: Sequence[float], resolution_hz: float,
                          n_harmonics: int, f_max: float | None = None) -> HarmonicBands:
    """:func:`harmonic_bands` of a record from its tachometer (``pulse_time``).

    A record without a single mapped tachometer has no speed: it gets no bands (every
    pole is then a ``mode``), unless ``orders`` are listed, which cannot be placed without
    a speed and are refused.

    Raises
    ------
    gbpipe.errors.DataError
        ``orders`` given for a record without ``pulse_time``.
    """
    if "pulse_time" not in record:
        if len(orders):
            raise DataError("pulse_time", f"the record has no tachometer, so its orders "
                            f"{list(orders)} cannot be placed: map one signal with quantity: "
                            "tacho, or remove orders")
        empty = np.array([])
        return HarmonicBands(empty, empty, empty, (np.nan, np.nan))
    shaft = shaft_frequency_range(np.asarray(record["pulse_time"].values, dtype=float),
                                  int(record.attrs["pulses_per_rev"]))
    return harmonic_bands(shaft, orders, resolution_hz, n_harmonics, f_max)


def label_poles(frequency_hz: np.ndarray, bands: HarmonicBands) -> np.ndarray:
    """``harmonic`` where a frequency lies inside a band, else ``mode``.

    Parameters
    ----------
    frequency_hz : array_like
        Pole or cluster frequencies [Hz], any shape.
    bands : HarmonicBands

    Returns
    -------
    ndarray of str, the shape of ``frequency_hz``
    """
    f = np.asarray(frequency_hz, dtype=float)
    inside = np.zeros(f.shape, bool)
    for low, high in zip(bands.low_hz, bands.high_hz, strict=True):
        inside |= (f >= low) & (f <= high)
    return np.where(inside, KINDS[1], KINDS[0])
