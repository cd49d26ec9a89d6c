"""The PDF test of one band: the band kurtosis, and its limit where a mode makes the band.

The band-passed response of a mode driven by random forces is Gaussian, kurtosis 3; a
sinusoid's is 1.5 (Brincker, Andersen & Møller, IMAC 2000). :func:`kurtosis_statistic`
reads it off the complex band signal of :func:`gbpipe.identify.band_signal.band_envelope`,
:func:`kurtosis_limit` draws its lower limit under the mode hypothesis, and
:func:`band_statistic` reads a band where the band itself holds its signal (a strong line
outside the band can leak through the low-pass's skirt). :mod:`gbpipe.identify.mode_kinds`
judges the clusters with it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import stats

from gbpipe.identify.band_signal import FILTER_ORDER, band_envelope, band_spectrum

__all__ = ["DRAWN_SAMPLES", "CHECK_ORDERS", "OWN_POWER", "kurtosis_statistic",
           "kurtosis_limit", "BandStatistic", "band_statistic"]

#: Monte Carlo draws of the statistic under the mode hypothesis (its mean and spread of
#: the log; the log-normal tail is taken, see :func:`kurtosis_limit`).
_DRAWS = 1000
#: Band-signal samples a draw holds at most [1]: a longer band's draws hold this many (and
#: at least 100 of the hypothesis' correlation times), the spread of their log statistic
#: scaled by sqrt(drawn / n). Its cost then grows as the bands, not as n log n each.
DRAWN_SAMPLES = 1 << 16
#: Steeper Butterworth orders a band signal that reads as a sinusoid is filtered again
#: with, in turn: a strong line outside the band leaks through the skirt of the order-4
#: low-pass (37 dB down at 1.7 cut-offs, 74 dB with order 8) and can hold the band signal.
CHECK_ORDERS = (8, 16)
#: Share of the band signal's power [1] a steeper filter keeps where the band holds it:
#: a flat band keeps 1.05 (order 8 against 4), a mode's more nearly 1; under this share,
#: what the wider skirt passed was a leak from outside the band.
OWN_POWER = 0.5


def kurtosis_statistic(z: np.ndarray) -> np.ndarray:
    """``1.5 E|z|^4 / (E|z|^2)^2`` along the last axis: the kurtosis of the real band signal
    (sinusoid 1.5, Gaussian 3) [1]."""
    p = np.abs(z) ** 2
    return 1.5 * np.mean(p ** 2, axis=-1) / np.mean(p, axis=-1) ** 2


def kurtosis_limit(f0: float, damping: float, half_width: float, fs_z: float, n: int,
                   alpha: float, rng: np.random.Generator, order: int = FILTER_ORDER
                   ) -> float:
    """Lowest band kurtosis a mode of ``f0``, ``damping`` gives with probability 1 - alpha.

    The hypothesis: the response of a single mode of natural frequency ``f0`` [Hz] and
    damping ratio ``damping`` [1] to white noise, through the band filter of
    :func:`gbpipe.identify.band_signal.band_envelope` (``half_width`` [Hz], Butterworth
    ``order``), ``n`` samples at ``fs_z`` [Hz]. Its complex band signal is drawn
    ``_DRAWS`` times by shaping white Gaussian noise with the mode's and the filter's
    spectrum; the limit is ``exp(mean - z_alpha sd)`` of the
    log statistic (the sample kurtosis is bounded below by 1 and skewed: its log is
    nearer normal). The fewer independent samples the band holds (light damping, short
    record), the wider the spread and the lower the limit. A band of more than
    :data:`DRAWN_SAMPLES` is drawn that long, or 100 correlation times ``1 / (2 pi
    damping f0)`` if longer, its spread scaled by ``sqrt(drawn / n)``: many correlation
    times long, the log statistic is a mean of a mixing series, whose spread falls as
    ``1 / sqrt(n)`` (its mean is that of ``n`` samples to ``O(1 / drawn)``).
    """
    drawn = min(n, max(DRAWN_SAMPLES, int(np.ceil(100 * fs_z / (2 * np.pi * damping * f0)))))
    nu = np.fft.fftfreq(drawn, 1.0 / fs_z)
    f = f0 + nu
    mode = 1.0 / np.abs(f0 ** 2 - f ** 2 + 2j * damping * f0 * f) ** 2
    low = 1.0 / (1.0 + (nu / half_width) ** (2 * order)) ** 2
    shape = np.sqrt(mode * low)
    logs = []
    for _ in range(0, _DRAWS, 250):  # batches bound the memory of long bands
        w = rng.standard_normal((250, drawn)) + 1j * rng.standard_normal((250, drawn))
        logs.append(np.log(kurtosis_statistic(np.fft.ifft(w * shape, axis=1))))
    lg = np.concatenate(logs)
    spread = lg.std(ddof=1) * np.sqrt(drawn / n)  # (1 exactly where the band is drawn whole)
    return float(np.exp(lg.mean() - stats.norm.isf(alpha) * spread))


class BandStatistic(NamedTuple):
    """The PDF test's reading of one output's band (:func:`band_statistic`).

    Attributes
    ----------
    power : float
        ``mean |z|^2`` of the band signal read [x's unit squared].
    kurtosis, limit : float
        Its statistic and the limit under the mode hypothesis [1].
    order : int
        Order of the low-pass whose band signal was read.
    note : str
        Why a steeper filter was read (empty where the order-4 band signal was).
    spectrum : tuple of ndarray or None
        The two-sided PSD of the band signal read, where it reads as a sinusoid
        (statistic under the limit): offsets from the band's centre [Hz] and PSD
        (:func:`~gbpipe.identify.band_signal.band_spectrum`), to tell where the sinusoid
        lies; else None.
    """

    power: float
    kurtosis: float
    limit: float
    order: int
    note: str
    spectrum: tuple[np.ndarray, np.ndarray] | None


def band_statistic(x: np.ndarray, fs: float, f0: float, damping: float, half_width: float,
                   alpha: float, rng: np.random.Generator, check_rng: np.random.Generator,
                   segment: float) -> BandStatistic:
    """The band kurtosis of ``x`` about ``f0`` and its limit, read where the band holds it.

    The band signal of the order-4 low-pass is read first. Where it reads as a sinusoid
    (statistic under the limit), the band is filtered again with each of
    :data:`CHECK_ORDERS` in turn (their start-up dropped until it has decayed below the
    band, ``settled``): a band signal that keeps under :data:`OWN_POWER` of its power
    through the steeper skirt was held by a leak from outside the band (a strong order
    line a few cut-offs away), and the steeper filter's reading replaces it, with its
    own limit. A line inside the band keeps its power through any of them.

    Parameters
    ----------
    x : ndarray
        Output signal sampled at ``fs`` [Hz].
    f0, damping : float
        The cluster [Hz] and the damping of the mode hypothesis [1].
    half_width : float
        Half-width of the band [Hz].
    alpha : float
        False-alarm probability of the limit.
    rng, check_rng : numpy.random.Generator
        Draws of the order-4 limit, and of the steeper filters' (apart, so that a check
        leaves the draws of the other clusters as they are).
    segment : float
        Segment of the band signal's spectrum [s]
        (:func:`~gbpipe.identify.band_signal.band_spectrum`): the record's frequency
        resolution.

    Returns
    -------
    BandStatistic
        The reading of the last filter whose band held its own power. Its ``power`` is
        the band's power the order lines' share is taken of
        (:func:`gbpipe.identify.band_signal.line_share`): a leak is no part of the band.
    """
    z, fs_z = band_envelope(x, fs, f0, half_width)
    power, k = float(np.mean(np.abs(z) ** 2)), float(kurtosis_statistic(z))
    limit = kurtosis_limit(f0, damping, half_width, fs_z, z.size, alpha, rng)
    first, used, note, read = power, FILTER_ORDER, "", (z, fs_z)
    for order in CHECK_ORDERS:
        # NaN (a band without power) reads as no sinusoid; a record too short for the
        # steeper filter's padding (3 (order + 1) samples) keeps the reading it has
        if not k < limit or x.size <= 3 * (order + 1):
            break
        zs, fs_s = band_envelope(x, fs, f0, half_width, order, settled=True)
        kept = float(np.mean(np.abs(zs) ** 2))
        if not kept < OWN_POWER * power:
            break
        power, k, used, read = kept, float(kurtosis_statistic(zs)), order, (zs, fs_s)
        limit = kurtosis_limit(f0, damping, half_width, fs_s, zs.size, alpha, check_rng,
                               order)
        ratio = f"{first / kept:.3g}" if kept > 0 else "inf"
        note = (f"a leak from outside the band held its order-{FILTER_ORDER} signal "
                f"({ratio} times the power an order-{order} filter keeps): read through "
                f"the order-{order} filter")
    spectrum = band_spectrum(*read, segment) if k < limit else None
    return BandStatistic(power, k, limit, used, note, spectrum)
