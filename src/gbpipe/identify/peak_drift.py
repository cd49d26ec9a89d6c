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
    """

    rho: float
    p: float
    n: int
    low_hz: float
    high_hz: float


def peak_drift(x: np.ndarray, fs: float, f0: float, half_width: float, segment: float
               ) -> Drift:
    """Does the spectral peak in ``f0 ± half_width`` drift with time, as a shaft's line does?

    The peak frequency of each non-overlapping Hann segment of ``segment`` [s] (4x
    zero-padded) within the band, against time: Spearman's rank correlation and its
    two-sided p-value (:func:`scipy.stats.spearmanr`). A line follows its shaft's speed,
    which drifts smoothly: a monotonic track; a mode's peak jitters at random about its
    frequency (no trend under the hypothesis of a mode: p uniform). The track's range
    tells whether it passes ``f0`` [Hz] (a track that leaves ``f0`` out follows a peak
    beside the pole, a line or another mode, not the pole's: :func:`cluster_evidence`).
    """
    n = int(round(segment * fs))
    f, _, pxx = signal.spectrogram(x - x.mean(), fs, nperseg=n, noverlap=0, nfft=4 * n)
    band = np.abs(f - f0) <= half_width
    if pxx.shape[1] < 4 or band.sum() < 2:
        return Drift(np.nan, 1.0, pxx.shape[1], np.nan, np.nan)
    track = f[band][np.argmax(pxx[band], axis=0)]
    low, high = float(track.min()), float(track.max())
    if np.ptp(track) == 0:
        return Drift(np.nan, 1.0, track.size, low, high)
    res = stats.spearmanr(np.arange(track.size), track)
    return Drift(float(res.statistic), float(res.pvalue), track.size, low, high)
