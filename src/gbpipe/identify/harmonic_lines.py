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
built with. Here a mode that happens to lie inside a band is ``harmonic``: the band
alone cannot separate the two. :mod:`gbpipe.identify.mode_kinds` measures the line itself
with the shaft's angle (:func:`reference_angle`) and keeps a mode that a weak line
crosses (docs/modal.md, "Criteria").
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import NamedTuple

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike
from scipy.integrate import cumulative_trapezoid

from gbpipe.errors import ConfigError, DataError
from gbpipe.harmonics import check_pulse_times, shaft_angle
from gbpipe.identify.windows import window_sums

__all__ = ["HarmonicBands", "shaft_frequency_range", "speed_frequency_range", "harmonic_bands",
           "record_harmonic_bands", "reference_angle", "order_one", "label_poles", "KINDS"]

#: The labels :func:`label_poles` gives (a cluster can also be ``spurious``:
#: :mod:`gbpipe.identify.mode_kinds`).
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
        The reference shaft's frequency range over the record ``(f_low, f_high)`` [Hz];
        NaN without a speed.
    source : str
        Where the speed comes from (``the tacho``, ``speed signal <name> (shaft order
        k)``, the record's own order-1 line), for the evidence of a label; empty: none.
    """

    order: np.ndarray
    low_hz: np.ndarray
    high_hz: np.ndarray
    shaft_hz: tuple[float, float]
    source: str = ""

    def inside(self, frequency_hz: ArrayLike) -> np.ndarray:
        """Mask of the bands ``frequency_hz`` [Hz] lies in.

        Shape (B,) for one frequency, (*shape, B) for an array of them.
        """
        f = np.asarray(frequency_hz, dtype=float)[..., None]  # one frequency: shape (1,)
        return (self.low_hz <= f) & (f <= self.high_hz)

    def overlapping(self, frequency_hz: float, half_width: float) -> np.ndarray:
        """Mask of the bands that overlap ``frequency_hz ± half_width`` [Hz]."""
        return ((self.low_hz <= frequency_hz + half_width)
                & (self.high_hz >= frequency_hz - half_width))

    def order_at(self, frequency_hz: float) -> float:
        """Order of the band ``frequency_hz`` [Hz] lies in (the lowest) [1], NaN for none."""
        inside = self.inside(frequency_hz)
        return float(self.order[inside][0]) if inside.any() else np.nan

    def widest(self, mask: np.ndarray) -> float:
        """Width of the widest of the bands ``mask`` selects [Hz], NaN for none: the widest
        peak an order line there can have (its order times the shaft's speed range, one
        frequency line on each side)."""
        return float(np.max(self.high_hz[mask] - self.low_hz[mask])) if mask.any() \
            else np.nan


def shaft_frequency_range(pulse_time: np.ndarray, pulses_per_rev: int, segment: float
                          ) -> tuple[float, float]:
    """Slowest and fastest mean shaft frequency of a pulse train over a Welch segment [Hz].

    Each frequency is that of the whole revolutions from one pulse to the first pulse
    that closes whole revolutions at least ``segment`` later, as
    :func:`speed_frequency_range` averages a speed signal: an order line in a Welch
    estimate sits at the shaft's mean frequency over a segment. A revolution's own speed
    is no line's frequency: a shaft's torsional vibration of angle amplitude A modulates
    the order-k line's phase, which keeps the carrier at the mean speed and adds
    sidebands (the carrier the strongest while k A < 1.43, where ``J_0 = J_1``), while a
    revolution's speed swings by A times the vibration's angular frequency (docs/modal.md,
    Criteria, "The speed"). Whole revolutions also cancel the tooth-spacing error of the
    wheel. A window is up to one revolution longer than ``segment``.

    Parameters
    ----------
    pulse_time : ndarray, shape (P,)
        Strictly increasing pulse times [s].
    pulses_per_rev : int
        Pulses per revolution of the tacho shaft, >= 1.
    segment : float
        Averaging length [s] (the Welch segment of the estimate), > 0.

    Returns
    -------
    (float, float)
        ``(f_low, f_high)`` [Hz].

    Raises
    ------
    gbpipe.errors.PulseError
        Non-increasing, missing or extra pulses (:func:`gbpipe.harmonics.check_pulse_times`).
    gbpipe.errors.DataError
        Pulses that do not span one segment in whole revolutions.
    """
    p = check_pulse_times(pulse_time).pulse_times
    ppr = int(pulses_per_rev)
    if ppr < 1:
        raise ConfigError("pulses_per_rev", f"must be >= 1; got {pulses_per_rev}")
    segment = float(segment)
    if not (np.isfinite(segment) and segment > 0):
        raise ConfigError("identify.nonparametric.segment",
                          f"must be a positive duration [s]; got {segment}")
    start = np.arange(p.size)
    # from each pulse, the first whole revolution ending a segment later or more
    end = start + ppr * np.ceil((np.searchsorted(p, p + segment) - start) / ppr).astype(int)
    ok = end < p.size
    if not ok.any():
        raise DataError("pulse_time", f"{p.size} pulses at {ppr} per revolution do not span "
                        f"one Welch segment ({segment:g} s) in whole revolutions: record a "
                        "longer run")
    f = (end[ok] - start[ok]) / ppr / (p[end[ok]] - p[start[ok]])
    return float(f.min()), float(f.max())


def speed_frequency_range(speed: np.ndarray, fs: float, shaft_order: float,
                          segment: float) -> tuple[float, float]:
    """Slowest and fastest reference-shaft frequency of a speed signal [Hz].

    The speed is averaged over the Welch segment of the estimate (``segment`` [s]): a line
    in that estimate sits at the mean shaft frequency of a segment, and the average
    removes the speed signal's noise (an encoder's derivative amplifies it).

    Parameters
    ----------
    speed : ndarray, shape (N,)
        Angular speed of the measured shaft [rad/s], sampled at ``fs`` [Hz].
    shaft_order : float
        The measured shaft turns at this multiple of the reference shaft the orders are
        referred to [1], > 0.
    segment : float
        Averaging length [s].

    Returns
    -------
    (float, float)
        ``(f_low, f_high)`` of the reference shaft [Hz].

    Raises
    ------
    gbpipe.errors.DataError
        A shaft that stands or turns both ways (the mean speed changes sign), or a record
        shorter than one segment.
    """
    n = int(round(segment * fs))
    s = np.abs(np.asarray(speed, float))
    if s.size < n or n < 1:
        raise DataError("speed", f"{s.size} samples are fewer than one Welch segment "
                        f"({n}): record a longer run")
    mean = window_sums(s, n) / n / (2 * np.pi * float(shaft_order))
    signed = window_sums(speed, n) / n
    if (np.any(signed > 0) and np.any(signed < 0)) or not np.all(mean > 0):
        raise DataError("speed", "the shaft stands or reverses within the record, so no "
                        "order line has a frequency: analyse a run at speed")
    return float(mean.min()), float(mean.max())


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
                          n_harmonics: int, f_max: float | None = None,
                          speeds: Mapping[str, float] | None = None,
                          segment: float | None = None) -> HarmonicBands:
    """:func:`harmonic_bands` of a record from its tachometer or a speed signal.

    The tachometer (``pulse_time``) when there is one: its shaft is the reference of the
    orders. Else the first of ``speeds`` (signal name -> shaft order of the measured
    shaft, ``measured.<record>.signals.<name>.shaft_order``; an encoder angle is stored
    as its speed). A record with neither gets no bands, unless ``orders`` are listed,
    which cannot be placed without a speed and are refused here
    (:func:`gbpipe.identify.record_modes` places them on the record's own order-1 line).

    Parameters
    ----------
    speeds : mapping str -> float, optional
        Speed signals [rad/s] of the record and the order of their shaft [1].
    segment : float, optional
        Averaging length of the tacho's or a speed signal's shaft frequency [s] (default
        ``1 / resolution_hz``): the Welch segment of the estimate the bands are used on.

    Raises
    ------
    gbpipe.errors.DataError
        ``orders`` given for a record with no speed; a speed signal missing or not in
        rad/s.
    """
    speed = next(iter(speeds or {}), None)  # the first speed signal, without a tacho
    if "pulse_time" not in record and speed is None:
        if len(orders):
            raise DataError("pulse_time", f"the record has no tachometer and no speed "
                            f"signal, so its orders {list(orders)} cannot be placed: map a "
                            "tacho, or give a speed or angle signal its shaft_order, or "
                            "remove orders")
        empty = np.array([])
        return HarmonicBands(empty, empty, empty, (np.nan, np.nan))
    welch = 1.0 / resolution_hz if segment is None else segment  # the estimate's segment
    if "pulse_time" in record:
        shaft = shaft_frequency_range(np.asarray(record["pulse_time"].values, dtype=float),
                                      int(record.attrs["pulses_per_rev"]), welch)
        return harmonic_bands(shaft, orders, resolution_hz, n_harmonics,
                              f_max)._replace(source="the tacho")
    if speed not in record or record[speed].attrs.get("units") != "rad/s":
        raise DataError(f"signal '{speed}'", "a signal with shaft_order must be a speed "
                        "(quantity: angle, or a value in an angular-speed unit such as "
                        "rpm or rad/s)")
    shaft_order = speeds[speed]
    shaft = speed_frequency_range(record[speed].values, float(record.attrs["sample_rate"]),
                                  shaft_order, welch)
    return harmonic_bands(shaft, orders, resolution_hz, n_harmonics, f_max)._replace(
        source=f"speed signal {speed} (shaft order {shaft_order:g})")


def reference_angle(record: xr.Dataset, times: np.ndarray,
                    speeds: Mapping[str, float] | None = None) -> np.ndarray | None:
    """The angle [rad] of the shaft :func:`record_harmonic_bands` refers the orders to.

    From the tachometer's pulses when the record has them (piecewise cubic through
    ``2 pi k / pulses_per_rev``, NaN outside the pulse train), else by integrating the
    first of ``speeds`` (a speed of a shaft at ``shaft_order`` times the reference) over
    the record's ``time``. Order ``k`` of the record's lines is then ``exp(i k angle)``.

    Parameters
    ----------
    record : xarray.Dataset
        A record as read (``time`` [s]; ``pulse_time`` [s] or the speed signals [rad/s]).
    times : ndarray
        Where to evaluate [s on the record's time axis].
    speeds : mapping str -> float, optional
        Speed signal name -> shaft order of its shaft, as for
        :func:`record_harmonic_bands`.

    Returns
    -------
    ndarray or None
        The angle at ``times``; None for a record with no speed.
    """
    times = np.asarray(times, dtype=float)
    if "pulse_time" in record:
        return shaft_angle(times, np.asarray(record["pulse_time"].values, dtype=float),
                           pulses_per_rev=int(record.attrs["pulses_per_rev"]))
    for name, shaft_order in (speeds or {}).items():
        t = np.asarray(record["time"].values, dtype=float)
        turned = cumulative_trapezoid(np.asarray(record[name].values, dtype=float), t,
                                      initial=0.0)
        return np.interp(times, t, turned / float(shaft_order), left=np.nan, right=np.nan)
    return None


def order_one(lines_hz: np.ndarray, orders: Sequence[float], resolution_hz: float,
              n_harmonics: int, f_max: float | None = None,
              speeds: Mapping[str, tuple[float, float]] | None = None) -> HarmonicBands:
    """Order lines from the record's own order-1 line, for a record with no known speed.

    The candidates for order 1 are the record's speed signals that no ``shaft_order``
    places (their own shaft's frequency range) and each line (a cluster the PDF or damping
    test called a sinusoid) taken as each order of the family ``1 .. max(n_harmonics, 1)``
    and ``orders`` in turn. The candidate whose family holds the most lines is taken (of
    equals: a speed signal, a measured range, before a line; then the first line, lowest,
    as the lowest order), when it holds one at least. A line's range is that
    of the lines within the resolution of it (the speed drifts: every method and pairing
    sees it at a slightly other frequency).

    Parameters
    ----------
    lines_hz : ndarray
        Frequencies of the clusters found to be sinusoids [Hz].
    orders, resolution_hz, n_harmonics, f_max
        As :func:`gbpipe.identify.harmonic_bands`.
    speeds : mapping str -> (float, float), optional
        Speed signals of the record -> their shaft's frequency range [Hz]
        (:func:`gbpipe.identify.harmonic_lines.speed_frequency_range`, shaft order 1).

    Returns
    -------
    HarmonicBands
        Empty when no candidate holds a line.
    """
    f = np.sort(np.asarray(lines_hz, float))
    k = np.concatenate([np.arange(1.0, max(int(n_harmonics), 1) + 1), list(orders)])
    cands = [((lo, hi), f"speed signal {name} taken as order 1 (its own shaft's lines; "
                        "no shaft_order given)") for name, (lo, hi) in (speeds or {}).items()]
    for f_line in f:
        same = f[np.abs(f - f_line) <= resolution_hz]
        for kk in np.unique(k):  # the line may be any order of the family
            cands.append(((float(same.min()) / kk, float(same.max()) / kk),
                          f"the record's own order-1 line at {f_line / kk:.2f} Hz (the line "
                          f"at {f_line:.2f} Hz as order {kk:.4g}; no speed measured)"))
    best, score = None, 0
    for (lo, hi), source in cands:
        hits = int(np.sum(np.any((f[:, None] >= k * lo - resolution_hz)
                                 & (f[:, None] <= k * hi + resolution_hz), axis=1)))
        if hits > score:
            best, score = ((lo, hi), source), hits
    if best is None:
        empty = np.array([])
        return HarmonicBands(empty, empty, empty, (np.nan, np.nan), "")
    return harmonic_bands(best[0], orders, resolution_hz, n_harmonics,
                          f_max)._replace(source=best[1])


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
    inside = bands.inside(frequency_hz).any(axis=-1)
    return np.where(inside, KINDS[1], KINDS[0])
