"""Checked inputs shared by the harmonic-removal methods beyond TSA.

* :func:`family_orders_checked` -- the families' orders as float arrays, checked;
* :func:`family_cycle` -- the fundamental (cycle) order of a family: the greatest common
  divisor of its orders, exact on Fractions;
* :class:`RecordAngle`, :func:`record_angle` -- a checked record with the shaft angle of
  every sample of its pulse span (the phase that VKF and regression track);
* :func:`removal_inputs` -- both, for the common signature of every method;
* :func:`angle_samples_per_rev`, :func:`to_angle`, :func:`subtract_angle_part` -- the
  angle-domain frame of DRS and cepstral editing: the record at constant angle, and an
  angle-domain estimate of the harmonics brought back onto the time samples and
  subtracted.

``Families`` is :data:`gbpipe.harmonics.metrics.Families` (name -> orders).

Why subtract an estimate instead of resampling the residual back: only the (band-limited,
smooth) harmonic estimate is interpolated twice; the broadband part of the record is never
resampled, so the removal cannot distort it by interpolation.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from scipy import fft as sfft

from gbpipe.harmonics.angle import AngleMap, angle_map, resample_map_to_angle
from gbpipe.harmonics.angle import evaluate_spline as spline_at
from gbpipe.harmonics.angle import spline_coefficients as spline_of
from gbpipe.harmonics.checks import as_count, as_order
from gbpipe.harmonics.metrics import Families
from gbpipe.harmonics.tacho import AngleMethod
from gbpipe.units import TWO_PI

__all__ = ["Families", "family_orders_checked", "family_cycle", "RecordAngle",
           "record_angle", "removal_inputs", "angle_samples_per_rev", "to_angle",
           "subtract_angle_part"]

#: Angle-domain points per period of the highest order: the cubic B-spline that brings an
#: angle-domain estimate back to time is then accurate far below -60 dB.
POINTS_PER_PERIOD = 16


def family_orders_checked(families: Families) -> dict[str, np.ndarray]:
    """Orders of each family as float arrays [HSS orders].

    Raises
    ------
    TypeError
        ``families`` is not a non-empty mapping.
    ValueError
        A family is empty or has an order <= 0.
    """
    if not isinstance(families, Mapping) or not families:
        raise TypeError("families must be a non-empty mapping name -> orders [HSS orders], "
                        "e.g. {'shaft': [1, 2, 3], 'mesh2': family_orders(ratio, 20)}")
    empty = [name for name, ords in families.items() if len(ords) == 0]
    if empty:
        raise ValueError(f"families {empty} have no order: give at least one each")
    return {str(name): np.array([as_order(o, f"families[{name!r}]") for o in ords])
            for name, ords in families.items()}


def family_cycle(orders: Sequence[float | Fraction]) -> Fraction:
    """Fundamental order of a family: the greatest common divisor of its orders.

    Exact for Fractions (teeth ratios); floats are first made Fractions with a
    denominator up to 10**6. ``[1, 2, 3]`` -> 1; ``[m, 2m, 3m]`` -> m.
    """
    fr = [o if isinstance(o, Fraction) else Fraction(float(o)).limit_denominator(10**6)
          for o in orders]
    den = math.lcm(*(f.denominator for f in fr))
    num = math.gcd(*(int(f * den) for f in fr))
    return Fraction(num, den)


@dataclass(frozen=True)
class RecordAngle:
    """A checked record and the shaft angle on its pulse span.

    Attributes
    ----------
    x : numpy.ndarray
        The record (a copy of nothing: the checked input; never modified here).
    fs : float
        Sample rate [Hz].
    amap : AngleMap
        Its angle map.
    span : slice
        Samples inside the pulse span (the only ones with a known angle).
    theta : numpy.ndarray
        Angle [rad] of the samples of ``span``.
    """

    x: np.ndarray
    fs: float
    amap: AngleMap
    span: slice
    theta: np.ndarray

    @property
    def times(self) -> np.ndarray:
        """Times [s] of the samples of ``span``."""
        return self.amap.t0 + np.arange(self.span.start, self.span.stop) / self.fs

    def shaft_rate(self) -> np.ndarray:
        """Shaft rotation rate [rev/s] of the samples of ``span`` (angle derivative)."""
        return np.gradient(self.theta, 1.0 / self.fs) / TWO_PI


def record_angle(x: np.ndarray, fs: float, pulse_times: np.ndarray, pulses_per_rev: int,
                 t0: float, method: AngleMethod) -> RecordAngle:
    """Check a record and its pulses; the angle of every sample of the pulse span.

    Raises
    ------
    DataError, PulseError
        As :func:`gbpipe.harmonics.resample_to_angle`.
    """
    x, fs, _, _, amap = angle_map(x, fs, pulse_times, pulses_per_rev, method, t0)
    span = slice(amap.i_lo, amap.i_hi + 1)
    theta = amap.theta[amap.i_lo - amap.j_lo:amap.i_hi - amap.j_lo + 1]
    return RecordAngle(x, fs, amap, span, theta)


def removal_inputs(x: np.ndarray, fs: float, pulse_times: np.ndarray, families: Families,
                   pulses_per_rev: int, t0: float,
                   method: AngleMethod) -> tuple[RecordAngle, dict[str, np.ndarray],
                                                 np.ndarray]:
    """The checked arguments of a removal method's common signature.

    Returns
    -------
    tuple
        The :class:`RecordAngle`, the families' orders (:func:`family_orders_checked`)
        and all their orders in one array [HSS orders].
    """
    rec = record_angle(x, fs, pulse_times, pulses_per_rev, t0, method)
    fam = family_orders_checked(families)
    return rec, fam, np.concatenate(list(fam.values()))


def angle_samples_per_rev(max_order: float) -> int:
    """Angle-domain points per revolution for orders up to ``max_order``: at least
    :data:`POINTS_PER_PERIOD` per period of the highest order, FFT-friendly."""
    return int(sfft.next_fast_len(int(np.ceil(POINTS_PER_PERIOD * max_order)), real=True))


def to_angle(rec: RecordAngle, max_order: float,
             samples_per_rev: int | None) -> tuple[np.ndarray, int]:
    """The record at constant angle, and its points per revolution (default
    :func:`angle_samples_per_rev` of ``max_order``)."""
    spr = (angle_samples_per_rev(max_order) if samples_per_rev is None
           else as_count(samples_per_rev, "samples_per_rev", 4))
    return resample_map_to_angle(rec.x, rec.amap, spr)[1], spr


def subtract_angle_part(rec: RecordAngle, part: np.ndarray, samples_per_rev: int) -> np.ndarray:
    """``x`` minus an angle-domain signal brought back onto the samples of the span.

    Parameters
    ----------
    rec : RecordAngle
        The record.
    part : numpy.ndarray
        Estimate of the harmonics at angles ``k 2 pi / samples_per_rev`` from the first
        pulse (as :func:`gbpipe.harmonics.resample_to_angle` returns them).
    samples_per_rev : int
        Points per revolution of ``part``.

    Returns
    -------
    numpy.ndarray
        The residual: ``x`` with the estimate subtracted on the span, unchanged outside.
    """
    pos = np.minimum(rec.theta * samples_per_rev / TWO_PI, part.size - 1)
    r = rec.x.copy()
    r[rec.span] -= spline_at(spline_of(part), pos)
    return r
