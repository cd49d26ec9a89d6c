"""Does the spectral peak near a pole drift with time, as a shaft's order line does?

Used by :mod:`gbpipe.identify.mode_kinds` (the drift test): a line follows its shaft's
speed, which drifts smoothly, so its peak moves along a monotonic track; a mode's peak
jitters at random about its frequency.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import signal, stats

__all__ = ["Drift", "peak_drift"]


class Drift(NamedTuple):
    """The peak track of one output near a cluster (:func:`peak_drift`).

    Attributes
    ----------
    rho : float
        Rank correlation of peak frequency and time [1] (NaN: a constant track).
    p : float
        Its two-sided p-value [1] (1 for a constant track).
    n : int
        Segments [1].
    low_hz, high_hz : float
        Lowest and highest peak of the track [Hz] (NaN: no track).
    gap_hz : float
        The track's closest approach to the band's centre [Hz] (NaN: no track).
    step_hz : float
        Size of the median signed change of the peak from one segment to the next [Hz]
        (NaN: no track): a sweep's steps share a sign, a track that jumps back and forth
        between two peaks has steps that cancel.
    """

    rho: float
    p: float
    n: int
    low_hz: float
    high_hz: float
    gap_hz: float
    step_hz: float


def peak_drift(x: np.ndarray, fs: float, f0: float, half_width: float, segment: float
               ) -> Drift:
    """Does the spectral peak in ``f0 ± half_width`` drift with time, as a shaft's line does?

    The peak frequency of each non-overlapping Hann segment of ``segment`` [s] (4x
    zero-padded) within the band, against time: Spearman's rank correlation and its
    two-sided p-value (:func:`scipy.stats.spearmanr`). A line follows its shaft's speed,
    which drifts smoothly: a monotonic track; a mode's peak jitters at random about its
    frequency (no trend under the hypothesis of a mode: p uniform). How near the track
    comes to ``f0`` [Hz] tells whether it passes the pole (a track that keeps away from
    ``f0`` follows a peak beside the pole, a line or another mode, or jumps between two:
    :func:`cluster_evidence`).
    """
    n = int(round(segment * fs))
    f, _, pxx = signal.spectrogram(x - x.mean(), fs, nperseg=n, noverlap=0, nfft=4 * n)
    band = np.abs(f - f0) <= half_width
    if pxx.shape[1] < 4 or band.sum() < 2:
        return Drift(np.nan, 1.0, pxx.shape[1], np.nan, np.nan, np.nan, np.nan)
    track = f[band][np.argmax(pxx[band], axis=0)]
    low, high = float(track.min()), float(track.max())
    gap, step = float(np.min(np.abs(track - f0))), abs(float(np.median(np.diff(track))))
    if np.ptp(track) == 0:
        return Drift(np.nan, 1.0, track.size, low, high, gap, step)
    res = stats.spearmanr(np.arange(track.size), track)
    return Drift(float(res.statistic), float(res.pvalue), track.size, low, high, gap, step)
