"""The signal of one frequency band: its complex envelope, and an order line's share of it.

:func:`band_envelope` demodulates a signal at a band's centre and low-passes it to the
band's half-width: the complex band signal whose statistics the harmonic tests of
:mod:`gbpipe.identify.mode_kinds` read (its kurtosis, its power). :func:`line_share`
measures an angle-locked order line with the shaft's angle and gives its power over the
band's: how much of a cluster's band a measured line holds (docs/modal.md, "Criteria").
"""

from __future__ import annotations

import numpy as np
from scipy import signal

__all__ = ["FILTER_ORDER", "band_envelope", "line_share"]

#: Order of the Butterworth low-pass of the complex demodulation (applied forward and
#: backward: |L|^4 of an order-4 filter, flat to within 0.1 dB to 0.7 of the cut-off).
FILTER_ORDER = 4


def band_envelope(x: np.ndarray, fs: float, f0: float, half_width: float
                  ) -> tuple[np.ndarray, float]:
    """The complex band signal of ``x`` around ``f0``: demodulated, low-passed, decimated.

    Parameters
    ----------
    x : ndarray, shape (N,)
        Signal, any unit, sampled at ``fs`` [Hz].
    f0 : float
        Centre of the band [Hz].
    half_width : float
        Half-width of the band [Hz] (the low-pass cut-off).

    Returns
    -------
    z : ndarray of complex, shape (M,)
        The band signal (``x``'s unit), sampled at four times the half-width or more,
        without the filter's start-up at either end.
    fs_z : float
        Its sample rate [Hz].
    """
    t = np.arange(x.size) / fs
    cut = min(half_width, 0.45 * fs)
    sos = signal.butter(FILTER_ORDER, cut, fs=fs, output="sos")
    z = signal.sosfiltfilt(sos, (x - x.mean()) * np.exp(-2j * np.pi * f0 * t))
    # the filter's start-up at either end (the record's first sample is a step from the
    # padding): a burst that no mode makes, dropped; 2 / cut is about three time
    # constants of the order-4 low-pass
    edge = min(int(2.0 * fs / cut), x.size // 4)
    step = max(1, int(fs // (4.0 * cut)))
    return z[edge:x.size - edge:step], fs / step


def line_share(x: np.ndarray, fs: float, angle: np.ndarray, order: float, f0: float,
               half_width: float) -> float:
    """Power of order ``order``'s line over the power of ``x`` in ``f0 ± half_width`` [1].

    The line's complex amplitude is the mean of ``x exp(-i order angle)`` over the record
    (a DFT in the angle domain: exact for an angle-locked line whatever its speed drift;
    random response and other orders average out as ``1 / sqrt(N)``); the band's power is
    the mean of ``|z|^2`` of its complex band signal (:func:`band_envelope`), of the same
    convention (a sinusoid of amplitude ``a`` gives ``a^2 / 4`` in both). About 1 for a
    line alone in its band, near 0 for a mode's random response with a weak line through
    it; above 1 when the line sweeps wider than the band.

    Parameters
    ----------
    x : ndarray, shape (N,)
        Signal sampled at ``fs`` [Hz].
    angle : ndarray, shape (N,)
        Reference shaft angle at its samples [rad] (NaN where unknown: left out).
    order : float
        Shaft order of the line [1].
    f0, half_width : float
        The cluster's band [Hz].
    """
    x = np.asarray(x, dtype=float) - np.mean(x)
    known = np.isfinite(angle)
    amplitude = np.mean(x[known] * np.exp(-1j * order * angle[known]))
    z, _ = band_envelope(x, fs, f0, half_width)
    return float(np.abs(amplitude) ** 2 / np.mean(np.abs(z) ** 2))
