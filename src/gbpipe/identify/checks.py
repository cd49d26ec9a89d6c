"""Signals an identification cannot use, refused before any fit.

A pairing whose input, output or measured reference (set-point) signal is constant gives
no model and no nonparametric reference: the Welch estimate through an all-zero
reference divides by zero, and what came out was a model scored against overflowed
numbers. An input without power in the identified band (``identify.frf``) excites
nothing there: its power in the band is below ``BAND_SHARE_MIN`` of its variance. Both
are refused at the start of the job, naming the record and signal.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import signal

from gbpipe.errors import DataError

__all__ = ["BAND_SHARE_MIN", "band_power_share", "check_signals"]

#: Least share of an input's variance in the identified band [-] (-60 dB). The share is
#: measured with a Blackman-Harris window (sidelobes below -92 dB) at a resolution of
#: f_min / 8, so a signal that is all below f_min / 2 (a slow manoeuvre) leaks less than
#: 1e-9 into the band and is refused; white noise 40 dB below such a manoeuvre passes.
BAND_SHARE_MIN = 1e-6

#: Relative size below which a variance or a band power is rounding, not signal: a few
#: ulps of float64 (2.2e-16) accumulated over the decimation filter and the mean.
_RELATIVE_ZERO = 1e-12


def band_power_share(x: np.ndarray, fs: float, band: tuple[float, float]) -> float:
    """Share of the variance of ``x`` (shape (n,)) in ``band`` [Hz] [-]; 0 for a constant.

    Welch estimate with a Blackman-Harris window at a resolution of ``band[0] / 8`` (or
    the whole record when shorter), so that power below the band does not leak into it.
    """
    x = np.asarray(x, float)
    nperseg = min(x.size, int(np.ceil(8 * fs / band[0])))
    f, p = signal.welch(x, fs, window="blackmanharris", nperseg=nperseg, detrend="constant")
    total = p[1:].sum()
    if not total > 0:
        return 0.0
    return float(p[(f >= band[0]) & (f <= band[1])].sum() / total)


def check_signals(where: str, names: Sequence[str], x: np.ndarray, role: str, fs: float,
                  band: tuple[float, float] | None = None) -> None:
    """Refuse a constant signal, or (with ``band``) one without power in the band.

    Parameters
    ----------
    where : str
        The record (e.g. ``record run12``), for the message.
    names : sequence of str
        Signal name of each column of ``x``.
    x : ndarray, shape (n, len(names))
        Conditioned signals (operating point removed, decimated) [SI].
    role : str
        ``input``, ``output`` or ``reference``, for the message.
    fs : float
        Sample rate of ``x`` [Hz].
    band : (float, float), optional
        Identified band [Hz]; each signal must carry power there (inputs).

    Raises
    ------
    gbpipe.errors.DataError
        Naming the record, the signal, what is wrong and the fix.
    """
    for k, name in enumerate(names):
        # NaN samples (a broken validation record) are the fit's failure, not "no variance"
        col = x[:, k][np.isfinite(x[:, k])]
        scale = float(np.max(np.abs(col))) if col.size else 0.0
        if not np.std(col) > _RELATIVE_ZERO * max(scale, np.finfo(float).tiny):
            raise DataError(f"{where}, signal {name}",
                            f"the {role} has no variance (constant after its operating point "
                            f"is removed): map the right channel in measured:, or drop it "
                            f"from the pairing's {role}s in identify.pairings")
        if band is not None and col.size == x.shape[0] and \
                band_power_share(col, fs, band) < BAND_SHARE_MIN:
            raise DataError(f"{where}, signal {name}",
                            f"the {role} has no power in the identified band {band[0]:g}-"
                            f"{band[1]:g} Hz (identify.frf): it excites nothing there; "
                            "identify a record with excitation in the band, or narrow "
                            "identify.frf to where it has some")
