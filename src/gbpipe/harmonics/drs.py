"""Discrete/random separation (DRS, Antoni and Randall 2004) in the angle domain.

A discrete (angle-locked) component is still correlated with itself many revolutions
later; a random one, whose correlation length is that of the bench's damped modes, is
not. DRS estimates, from Welch averages over segments shorter than the delay, the
filter that predicts the signal from its copy delayed by ``delay_revs`` revolutions; its
gain is the magnitude coherence ``|gamma(o)|`` between the two, ~1 at discrete orders
and ~0 elsewhere (bias ~``1 / sqrt(segments)``): the Wiener gain ``SNR / (1 + SNR)`` of
each order bin. Applied as a zero-phase filter to the signal, it
gives the discrete part; the residual is the signal minus it. A line keeps
``1 / (1 + SNR)`` of its amplitude: the attenuation is twice the line-to-random ratio
of its Welch bin, in dB.

Why the angle domain. On a speed sweep a harmonic is a chirp in time and no fixed delay
in seconds keeps it coherent; at constant angle every order is a fixed line and the
delay is a whole number of revolutions. The signal is therefore resampled to constant
angle (:mod:`gbpipe.harmonics.angle`), and only the estimated discrete part is brought
back to the time samples and subtracted (:func:`gbpipe.harmonics.removal_inputs.
subtract_angle_part`), so the broadband part is never interpolated. A resonance, at fixed
Hz, moves through the orders during a sweep: it stays random in the angle domain.

Gain restricted to the families: classic DRS removes every discrete component; with
``band`` (default), the gain is kept only within ``band`` orders of the families'
orders, so other angle-locked content (and the random part elsewhere) is left alone.
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sfft
from scipy import signal

from gbpipe.harmonics.checks import as_count, as_positive, check_overlap
from gbpipe.harmonics.removal_inputs import (
    Families,
    removal_inputs,
    subtract_angle_part,
    to_angle,
)
from gbpipe.harmonics.tacho import AngleMethod

__all__ = ["drs_gain", "apply_gain", "residual_drs"]


def drs_gain(xa: np.ndarray, samples_per_rev: int, segment_revs: int, delay_revs: int,
             overlap: float, window: str | tuple) -> tuple[np.ndarray, np.ndarray]:
    """DRS gain: magnitude coherence of the angle-domain signal with its delayed copy.

    Parameters
    ----------
    xa : numpy.ndarray
        Signal at constant angle, ``samples_per_rev`` points per revolution.
    samples_per_rev : int
        Points per revolution.
    segment_revs, delay_revs : int
        Welch segment length and delay [revolutions]; ``delay_revs > segment_revs``.
    overlap : float
        Segment overlap [0, 1).
    window : str or tuple
        Window of the segments (:func:`scipy.signal.get_window`).

    Returns
    -------
    orders : numpy.ndarray
        Order of each bin [-], resolution ``1 / segment_revs``.
    gain : numpy.ndarray
        ``|gamma|`` in [0, 1] [-].
    """
    n_seg = segment_revs * samples_per_rev
    lag = delay_revs * samples_per_rev
    orders, coh = signal.coherence(xa[lag:], xa[:-lag], fs=samples_per_rev, window=window,
                                   nperseg=n_seg, noverlap=int(overlap * n_seg),
                                   detrend=False)
    return orders, np.sqrt(coh)


def apply_gain(xa: np.ndarray, orders: np.ndarray, gain: np.ndarray,
               samples_per_rev: int, pad: int) -> np.ndarray:
    """Zero-phase filtering of a whole angle-domain record by a gain given per order.

    The gain is interpolated linearly onto the record's own (fine) order grid and applied
    by one FFT of the zero-padded record: a line between two Welch bins sees the gain
    of its neighbours, not the ripple of a frequency-sampled FIR between bins; the
    ``pad`` zeros (>= the filter's impulse response) keep the two ends from wrapping.
    """
    n_fft = sfft.next_fast_len(xa.size + 2 * pad, real=True)
    spec = sfft.rfft(xa, n_fft)
    spec *= np.interp(sfft.rfftfreq(n_fft, 1.0 / samples_per_rev), orders, gain)
    return sfft.irfft(spec, n_fft)[:xa.size]


def residual_drs(x: np.ndarray, fs: float, pulse_times: np.ndarray, families: Families,
                 pulses_per_rev: int = 1, *, segment_revs: int = 16,
                 delay_revs: int | None = None, overlap: float = 0.75,
                 band: float | None = 0.125, samples_per_rev: int | None = None,
                 window: str | tuple = "hann", t0: float = 0.0,
                 method: AngleMethod = "pchip") -> np.ndarray:
    """Remove order families by discrete/random separation in the angle domain.

    Parameters
    ----------
    x, fs, pulse_times, families, pulses_per_rev, t0, method
        The common signature (:func:`gbpipe.harmonics.removal.remove_harmonics`).
        Only the families are removed (``band``), not every discrete component.
    segment_revs : int
        Welch segment length [revolutions]: order resolution ``1 / segment_revs``;
        longer separates closer orders and raises each line above the random part.
    delay_revs : int, optional
        Delay [revolutions]: more than ``segment_revs`` plus the correlation length of the
        random part (a mode of damping ``zeta`` at ``f`` Hz: ``~1 / (zeta 2 pi f)`` s), so
        that a segment and its delayed copy share no sample of the random part (else
        their Welch cross-spectrum is that of the same samples, and every bin looks
        discrete). Default ``segment_revs + 4``.
    overlap : float
        Welch segment overlap [0, 1).
    band : float or None
        Keep the gain only within ``band`` orders of the families' orders; None: classic
        DRS (every discrete component is removed).
    samples_per_rev : int, optional
        Angle-domain points per revolution; default 16 per period of the highest order.
    window : str or tuple
        Welch window.

    Returns
    -------
    numpy.ndarray
        The residual: ``x`` minus the discrete part in the bands (unit of ``x``).

    Raises
    ------
    ValueError
        Record shorter than two segments plus the delay; bad counts or band.
    """
    rec, _, orders = removal_inputs(x, fs, pulse_times, families, pulses_per_rev, t0, method)
    segment_revs = as_count(segment_revs, "segment_revs", 2)
    delay_revs = (segment_revs + 4 if delay_revs is None
                  else as_count(delay_revs, "delay_revs", segment_revs + 1))
    overlap = check_overlap(overlap)
    xa, spr = to_angle(rec, float(orders.max()), samples_per_rev)
    if xa.size < (2 * segment_revs + delay_revs) * spr:
        raise ValueError(f"the record spans {xa.size / spr:.1f} revolutions: DRS needs at "
                         f"least 2 x segment_revs + delay_revs = "
                         f"{2 * segment_revs + delay_revs}; shorten segment_revs")
    ords, gain = drs_gain(xa, spr, segment_revs, delay_revs, overlap, window)
    if band is not None:
        band = as_positive(band, "band", "orders")
        near = np.zeros(ords.size, dtype=bool)
        for o in orders:  # a few tens of orders
            near |= np.abs(ords - o) <= band
        gain = np.where(near, gain, 0.0)
    discrete = apply_gain(xa, ords, gain, spr, segment_revs * spr)
    return subtract_angle_part(rec, discrete, spr)
