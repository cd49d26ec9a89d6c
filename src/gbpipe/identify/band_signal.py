"""The signal of one frequency band: its complex envelope, and an order line's share of it.

:func:`band_envelope` demodulates a signal at a band's centre and low-passes it to the
band's half-width: the complex band signal whose statistics the harmonic tests of
:mod:`gbpipe.identify.mode_kinds` read (its kurtosis, its power, its spectrum:
:func:`band_spectrum`). :func:`line_share`
measures angle-locked order lines with the shaft's angle and gives their power over the
band's, with an upper bound: how much of a cluster's band the measured lines hold
(docs/modal.md, "Criteria").
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from scipy import signal

__all__ = ["FILTER_ORDER", "LOCKED_SPAN", "band_envelope", "band_spectrum", "LineShare",
           "line_share"]

#: Order of the Butterworth low-pass of the complex demodulation (applied forward and
#: backward: |L|^4 of an order-4 filter, flat to within 0.1 dB to 0.7 of the cut-off).
FILTER_ORDER = 4


def band_envelope(x: np.ndarray, fs: float, f0: float, half_width: float,
                  order: int = FILTER_ORDER, settled: bool = False
                  ) -> tuple[np.ndarray, float]:
    """The complex band signal of ``x`` around ``f0``: demodulated, low-passed, decimated.

    Parameters
    ----------
    x : ndarray, shape (N,)
        Signal, any unit.
    fs : float
        Its sample rate [Hz].
    f0 : float
        Centre of the band [Hz].
    half_width : float
        Half-width of the band [Hz] (the low-pass cut-off).
    order : int
        Order of the Butterworth low-pass (default :data:`FILTER_ORDER`).
    settled : bool
        Drop the low-pass's start-up at either end until it has decayed to a tenth of the
        band signal's rms, whatever the power outside the band: ``tau ln(10 sqrt(P_x /
        P_z))``, ``tau`` the time constant of the filter's slowest pole, ``P_x`` the
        signal's power and ``P_z`` the band signal's over the record's middle half (a
        strong line outside the band starts the filter as strongly as it drives the
        input). Default: ``2 / cut``, about five time constants of the order-4
        low-pass, enough where the band holds most of the power that passes. Either is
        capped at a quarter of the record at each end (a narrow band on a short record
        may then keep some of the start-up: it adds power and bursts, never a sinusoid).

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
    sos = signal.butter(order, cut, fs=fs, output="sos")
    xc = x - x.mean()
    z = signal.sosfiltfilt(sos, xc * np.exp(-2j * np.pi * f0 * t))
    # the filter's start-up at either end (the record's first sample is a step from the
    # padding): a burst that no mode makes, dropped
    if settled:
        tau = 1.0 / (2.0 * np.pi * cut * np.sin(np.pi / (2 * order)))
        inner = float(np.mean(np.abs(z[x.size // 4: 3 * x.size // 4]) ** 2))
        ratio = float(np.mean(xc ** 2)) / inner if inner > 0 else 1.0
        edge = min(int(tau * np.log(10.0 * np.sqrt(max(ratio, 1.0))) * fs), x.size // 4)
    else:
        edge = min(int(2.0 * fs / cut), x.size // 4)
    step = max(1, int(fs // (4.0 * cut)))
    return z[edge:x.size - edge:step], fs / step


def band_spectrum(z: np.ndarray, fs_z: float, segment: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The two-sided Welch PSD of the band signal ``z``, about the band's centre.

    Hann segments of ``segment`` [s] (the record's frequency resolution; the whole
    signal where it is shorter), 4x zero-padded, no detrending (a line at the centre is
    a constant ``z``). A steady line spans the Hann window's half-power width (1.44
    frequency lines); a line that follows a drifting speed spans its sweep, which the
    segments' average holds.

    Parameters
    ----------
    z : ndarray of complex
        Band signal (:func:`band_envelope`).
    fs_z : float
        Its sample rate [Hz].
    segment : float
        Segment length [s].

    Returns
    -------
    offset : ndarray
        Frequencies as offsets from the band's centre, ascending [Hz].
    psd : ndarray
        The PSD there [``z``'s unit squared per Hz].
    """
    n = min(z.size, max(int(round(segment * fs_z)), 1))
    f, pxx = signal.welch(z, fs_z, nperseg=n, nfft=4 * n, detrend=False,
                          return_onesided=False)
    order = np.argsort(f)
    return f[order], pxx[order]


class LineShare(NamedTuple):
    """An order line's power over its band's (:func:`line_share`).

    Attributes
    ----------
    share : float
        The line's power over the band's [1] (0 when the line is not above the noise
        floor; above 1 when the line sweeps wider than the band).
    bound : float
        Its upper bound at the asked probability [1].
    """

    share: float
    bound: float


#: Longest stretch [s] over which a line's phase is trusted to stay locked to the angle:
#: an order given to 4 decimals (error up to 5e-5) on a shaft of up to 50 Hz turns by
#: at most 2 pi 5e-5 50 32 = 0.5 rad in it (2 % of the line's power lost).
LOCKED_SPAN = 32.0


def line_share(x: np.ndarray, fs: float, angle: np.ndarray, orders: Sequence[float],
               segment: float, band_power: float, z_alpha: float) -> LineShare:
    """Power of the order lines ``orders`` in ``x`` over ``band_power``, with its bound.

    ``x exp(-i k angle)`` turns order ``k``'s angle-locked line into a constant phasor
    ``c`` whatever the speed's drift. Its mean over each segment of ``segment`` seconds
    (the Welch segment of the estimate) is ``c`` plus the random response's projection,
    which is independent from segment to segment with the power ``s2`` the response has
    at the line (the segments' scatter measures it there, not beside the line). Over
    ``m`` segments ``|mean|^2 - scatter / m`` is then an unbiased estimate of ``|c|^2``.
    It is taken over stretches of at most :data:`LOCKED_SPAN` (a rounded order or a
    speed signal slightly off in gain turns the phasor slowly: over an hour it would
    average the line away) and averaged; the lines of ``orders`` add. The bound adds
    ``z_alpha`` standard errors, ``sqrt(2 |c|^2 s2 / m + (s2 / m)^2)`` per stretch. Powers
    are in :func:`band_envelope`'s convention (a sinusoid of amplitude ``a``: ``a^2 / 4``).
    (:func:`gbpipe.harmonics.tracking.order_amplitudes` measures orders too, but on the
    angle-resampled record of a tacho and windowed; here a speed signal serves as well,
    and the segments' scatter is the point.)

    Parameters
    ----------
    x : ndarray, shape (N,)
        Signal, mean removed, sampled at ``fs`` [Hz].
    fs : float
        Sample rate [Hz].
    angle : ndarray, shape (N,)
        Reference shaft angle at the samples [rad]; NaN where unknown (only the samples
        between the first and last known one are used).
    orders : sequence of float
        Shaft orders of the lines [1] (those whose band holds the cluster).
    segment : float
        Segment length [s].
    band_power : float
        ``mean |z|^2`` of the band signal (:func:`band_envelope`), ``x``'s unit squared.
    z_alpha : float
        Standard-normal quantile of the bound.

    Returns
    -------
    LineShare
        NaN (no decision) when fewer than two segments have an angle or the band holds no
        power.
    """
    known = np.flatnonzero(np.isfinite(angle))
    n = int(round(segment * fs))
    segments = (known[-1] + 1 - known[0]) // n if known.size else 0
    if segments < 2 or not band_power > 0:
        return LineShare(np.nan, np.nan)
    span = slice(known[0], known[0] + segments * n)
    xs, th = np.asarray(x, dtype=float)[span], np.asarray(angle, dtype=float)[span]
    stretches = -(-segments // max(2, int(LOCKED_SPAN // segment)))
    est, var = 0.0, 0.0
    for k in orders:
        a = (xs * np.exp(-1j * k * th)).reshape(segments, n).mean(axis=1)
        for part in np.array_split(a, stretches):
            m, s2 = part.size, np.sum(np.abs(part - part.mean()) ** 2) / (part.size - 1)
            power = np.abs(part.mean()) ** 2 - s2 / m
            est += power / stretches
            var += (2 * max(power, 0.0) * s2 / m + (s2 / m) ** 2) / stretches ** 2
    return LineShare(max(est, 0.0) / band_power,
                     (est + z_alpha * np.sqrt(var)) / band_power)
