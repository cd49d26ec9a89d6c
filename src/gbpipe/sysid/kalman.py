"""Noise model of the identified system: steady-state Kalman gain of the innovation form.

The subspace methods estimate the covariances of the state and output residuals; the gain
``K`` of ``x+ = A x + B u + K e``, ``y = C x + D u + e`` follows from the discrete algebraic
Riccati equation, and ``A - K C`` (the predictor) must be stable for the model to be usable
as a one-step predictor.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla

from gbpipe.errors import DataError

__all__ = ["kalman_gain", "stable_predictor_gain"]


def _psd_part(m: np.ndarray) -> np.ndarray:
    """Nearest positive semi-definite matrix (negative eigenvalues set to zero)."""
    m = 0.5 * (m + m.T)
    w, v = np.linalg.eigh(m)
    return (v * np.maximum(w, 0.0)) @ v.T


def kalman_gain(
    a: np.ndarray, c: np.ndarray, q: np.ndarray, r: np.ndarray, s: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """Steady-state Kalman (innovation-form) gain and innovation covariance.

    Model ``x+ = A x + w``, ``y = C x + v`` with ``cov([w; v]) = [[Q, S], [S', R]]``.
    Returns ``(K, C P C' + R)`` or ``None`` when the Riccati equation has no stabilising
    solution.
    """
    n, l_ = a.shape[0], c.shape[0]
    full = _psd_part(np.block([[q, s], [s.T, r]]))
    q, s, r = full[:n, :n], full[:n, n:], full[n:, n:]
    # A tiny floor keeps R invertible when an output is (numerically) noise-free.
    r = r + 1e-12 * max(np.trace(r) / l_, 1e-300) * np.eye(l_) + 1e-300 * np.eye(l_)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            p = sla.solve_discrete_are(a.T, c.T, q, r, s=s)
    except (np.linalg.LinAlgError, ValueError):
        return None
    if not np.all(np.isfinite(p)):
        return None
    re = c @ p @ c.T + r
    k = np.linalg.solve(re.T, (a @ p @ c.T + s).T).T
    if np.max(np.abs(np.linalg.eigvals(a - k @ c))) >= 1.0:
        return None
    return k, 0.5 * (re + re.T)


def stable_predictor_gain(
    a: np.ndarray, c: np.ndarray, k: np.ndarray, q: np.ndarray, r: np.ndarray, s: np.ndarray
) -> np.ndarray:
    """Return ``k`` if ``A - K C`` is stable, otherwise a Kalman gain that makes it stable.

    The fall-back chain is the Kalman gain of the estimated covariances, then that of
    regularised covariances (``Q + I``, which has a stabilising solution whenever ``(A, C)``
    is detectable).

    Raises
    ------
    DataError
        ``(A, C)`` is not detectable, so no gain can stabilise the predictor.
    """
    if np.max(np.abs(np.linalg.eigvals(a - k @ c))) < 1.0:
        return k
    for q_try in (q, q + np.eye(a.shape[0]) * max(np.trace(q) / a.shape[0], 1.0)):
        res = kalman_gain(a, c, q_try, r, s)
        if res is not None:
            return res[0]
    raise DataError(
        "model",
        "no stable predictor exists: the estimated (A, C) is not detectable; try another "
        "order",
    )
