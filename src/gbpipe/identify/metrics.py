"""Comparison of an identified model with the true model: FRF error, match bandwidth, modes.

Match bandwidth: on a log-spaced grid ``f_min .. f_max``, the highest grid frequency ``f``
such that ``|error|`` stays within the tolerance (1 dB) at *every* grid point from
``f_min`` to ``f``; 0 when the first grid point already fails. The lower end ``f_min``
(5 Hz in config) is above the bench's motor-against-motor mode (0.9-1.3 Hz, lightly
damped, even unstable with only the torque loop closed) and the speed and torque loops
(bandwidths of a few Hz): there the *other* motor's unmeasured ripple reaches every speed
almost undamped, so a single-input model sees mostly noise, and 20-45 s records hold only a
few cycles. The table also gives the share of grid points within tolerance, which shows
good fits above a low-frequency miss.
"""

from __future__ import annotations

import numpy as np

from gbpipe.lti import modes

__all__ = ["frf_error_db", "match_bandwidth", "identified_modes", "match_modes"]


def frf_error_db(g_id: np.ndarray, g_true: np.ndarray) -> np.ndarray:
    """Magnitude error ``20 log10(|G_id| / |G_true|)`` [dB], elementwise."""
    tiny = np.finfo(float).tiny
    return 20.0 * np.log10(np.maximum(np.abs(g_id), tiny) / np.maximum(np.abs(g_true), tiny))


def match_bandwidth(f_hz: np.ndarray, err_db: np.ndarray, tol_db: float = 1.0) -> float:
    """Highest grid frequency up to which ``|err_db| <= tol_db`` everywhere [Hz].

    Parameters
    ----------
    f_hz : ndarray, shape (nf,)
        Ascending grid [Hz].
    err_db : ndarray, shape (nf,) or (nf, ...)
        Error per grid point; extra axes (outputs, inputs) must *all* be within tolerance.
    tol_db : float
        Tolerance [dB], > 0.

    Returns
    -------
    float
        Bandwidth [Hz]; 0.0 if the first grid point fails, ``f_hz[-1]`` if none fails.
    """
    e = np.abs(np.asarray(err_db)).reshape(len(f_hz), -1)
    ok = np.all(e <= tol_db, axis=1) & np.all(np.isfinite(e), axis=1)
    if ok.all():
        return float(f_hz[-1])
    first_bad = int(np.argmin(ok))
    return 0.0 if first_bad == 0 else float(f_hz[first_bad - 1])


def identified_modes(A: np.ndarray, dt: float, f_max: float, zeta_max: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Lightly damped modes of an identified discrete model up to ``f_max`` [Hz].

    Returns
    -------
    freq_hz, zeta : ndarray
        Natural frequencies [Hz] (ascending) and damping ratios (:func:`gbpipe.lti.modes`)
        of the modes with ``freq_hz <= f_max`` and ``zeta <= zeta_max``.
    """
    f, z = modes(A, dt)
    keep = (f <= f_max) & (z <= zeta_max)
    return f[keep], z[keep]


def match_modes(f_true: np.ndarray, f_id: np.ndarray) -> np.ndarray:
    """Identified frequency nearest to each true mode (NaN when none was identified)."""
    f_id = np.asarray(f_id, dtype=float)
    if f_id.size == 0:
        return np.full(len(f_true), np.nan)
    return np.array([f_id[np.argmin(np.abs(f_id - ft))] for ft in f_true])
