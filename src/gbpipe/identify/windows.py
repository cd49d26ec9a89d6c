"""Where a measured record is excited: its operating-point stretch and its hold-out window.

The simulated campaign knows both (``campaign.settle``, and a validation record of its
own). A bench record does not: a fixed settle may swallow the first excitation burst, and
a fixed last quarter may hold no excitation at all (every model then scores a few %). So
both are read from the record's inputs, in the identified band (``identify.frf``):

* :func:`excitation_onset`: the first moment the inputs carry band power, from a running
  band-power envelope; the operating point is the mean *before* it (at most
  ``campaign.settle``);
* :func:`holdout_window`: a window of ``identify.holdout`` of the record whose mean band
  power of the inputs is at least ``identify.holdout_power_min`` (0.1: -10 dB) of the
  record's mean, the latest such window (the record's end when it qualifies, as before);
  the fit uses the rest, in pieces (a multi-experiment fit: :mod:`gbpipe.sysid` takes
  lists of records). Relative to the mean, not a share of the total: a record whose band
  power sits in a few torque steps keeps its excited end (holding the floor of random
  excitation) rather than losing a step to the hold-out.

Either can be set per record instead (``measured.<record>.validation: {start, end}`` [s]).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from scipy import signal

__all__ = ["band_energy", "window_sums", "excitation_onset", "Holdout", "holdout_window",
           "fit_pieces"]

#: A running window whose band power is below this share of the record's strongest
#: window (-20 dB) is not excited: a burst and its quiet neighbours differ by much more,
#: stationary noise by much less (tested over several records in tests/identify).
_QUIET = 0.01


def band_energy(x: np.ndarray, fs: float, band: tuple[float, float]) -> np.ndarray:
    """Band power per sample of the channels of ``x`` (shape (n, c)), each channel
    normalised by its own total band energy (so every input counts alike) [-].

    Zero-phase 4th-order Butterworth band-pass (time alignment matters, phase does not).
    """
    x = np.asarray(x, float).reshape(len(x), -1)
    hi = min(band[1], 0.45 * fs)
    sos = signal.butter(4, [band[0], hi], btype="bandpass", fs=fs, output="sos")
    xb = signal.sosfiltfilt(sos, x - x.mean(axis=0), axis=0)
    p = xb**2
    tot = p.sum(axis=0)
    return (p / np.where(tot > 0, tot, 1.0)).sum(axis=1) / p.shape[1]


def window_sums(x: np.ndarray, n: int) -> np.ndarray:
    """Sum of every ``n`` consecutive samples of ``x`` (each full window, ``len(x) - n + 1``
    of them), in the unit of ``x``: from the running sum, O(len(x)), where a convolution
    with the window costs ``n`` per sample (13 s of CPU for 1-s windows on an hour at
    5 kHz; the difference of two running sums rounds to about ``len(x) / n`` eps of the
    window's sum, 4e-12 there)."""
    cum = np.concatenate([[0.0], np.cumsum(np.asarray(x, float))])
    return cum[n:] - cum[:-n]


def excitation_onset(x: np.ndarray, fs: float, band: tuple[float, float],
                     window_s: float) -> float:
    """Start of the first excited running window of the inputs ``x`` [s].

    Parameters
    ----------
    x : ndarray, shape (n, c)
        Input signals at ``fs`` [Hz], any unit.
    band : (float, float)
        Identified band [Hz].
    window_s : float
        Running-window length [s] (the nonparametric estimate's segment).

    Returns
    -------
    float
        Time of the first window whose band power reaches 1 % of the strongest window's.
    """
    e = band_energy(x, fs, band)
    n_w = max(1, int(round(window_s * fs)))
    if e.size < n_w:
        return 0.0
    power = window_sums(e, n_w)
    return float(np.argmax(power >= _QUIET * power.max()) / fs)


class Holdout(NamedTuple):
    """The held-out window ``[start, stop)`` [samples] and its share of the band power
    [-]; ``source`` says how it was chosen."""

    start: int
    stop: int
    power_share: float
    source: str


def holdout_window(energy: np.ndarray, share: float, power_min: float, fs: float,
                   user: tuple[float, float] | None = None) -> Holdout:
    """The hold-out window of a record from its band energy per sample.

    Parameters
    ----------
    energy : ndarray, shape (n,)
        :func:`band_energy` of the (conditioned) inputs.
    share : float
        Window length as a share of the record (``identify.holdout``) [-].
    power_min : float
        Least mean band power of the window relative to the record's mean
        (``identify.holdout_power_min``) [-]: the window holds at least
        ``power_min * share`` of the band energy.
    fs : float
        Sample rate of ``energy`` [Hz].
    user : (float, float), optional
        ``measured.<record>.validation`` ``start, end`` [s from the start of ``energy``]:
        taken as given.

    Returns
    -------
    Holdout
        The latest window of ``share`` that holds ``power_min * share`` of the band energy;
        if none does, the one holding the most (its ``source`` says it falls short).
    """
    n = energy.size
    cum = np.concatenate([[0.0], np.cumsum(energy)])
    total = cum[-1] if cum[-1] > 0 else 1.0
    if user is not None:
        a, b = (int(round(t * fs)) for t in user)
        a, b = max(0, min(a, n)), max(0, min(b, n))
        return Holdout(a, b, float((cum[b] - cum[a]) / total),
                       f"measured.<record>.validation: {user[0]:g}-{user[1]:g} s")
    n_val = int(round(share * n))
    held = window_sums(energy, n_val) / total  # window starting at each sample
    ok = np.flatnonzero(held >= power_min * n_val / n)
    if ok.size:
        k = int(ok[-1])
        return Holdout(k, k + n_val, float(held[k]),
                       f"the latest {share:g} of the record whose inputs' band power is >= "
                       f"{power_min:g} of the record's mean")
    k = int(np.argmax(held))
    return Holdout(k, k + n_val, float(held[k]),
                   f"no {share:g} of the record reaches {power_min:g} of the inputs' mean "
                   f"band power: the window holding the most ({held[k]:.3g} of it)")


def fit_pieces(x: np.ndarray, hold: Holdout, min_len: int) -> list[np.ndarray]:
    """The parts of ``x`` before and after the hold-out window, each at least ``min_len``
    samples long (shorter ones hold too few data windows to add anything)."""
    pieces: Sequence[np.ndarray] = (x[:hold.start], x[hold.stop:])
    return [p for p in pieces if len(p) >= min_len]
