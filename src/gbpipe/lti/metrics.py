"""The one fit metric of gbpipe: normalised root-mean-square fit in percent."""

from __future__ import annotations

import numpy as np

__all__ = ["fit_percent"]


def fit_percent(y: np.ndarray, y_sim: np.ndarray) -> np.ndarray:
    """NRMSE fit ``100 (1 - ||y - y_sim|| / ||y - mean y||)`` per output [%].

    Parameters
    ----------
    y : array_like, shape (N,) or (N, p)
        Measured output.
    y_sim : array_like, same size as `y`
        Simulated (or predicted) output.

    Returns
    -------
    ndarray, shape (p,)
        100 for a perfect fit, 0 for the mean, negative when worse than the mean.
        ``-inf`` where the fit is undefined (NaN or inf in the data, constant `y`): a
        non-finite fit is a failure, never a number that looks like one.
    """
    y = np.asarray(y, dtype=float).reshape(len(y), -1)
    y_sim = np.asarray(y_sim, dtype=float).reshape(len(y), -1)
    with np.errstate(all="ignore"):
        num = np.linalg.norm(y - y_sim, axis=0)
        den = np.linalg.norm(y - y.mean(axis=0), axis=0)
        out = 100.0 * (1.0 - num / den)
    return np.where(np.isfinite(out), out, -np.inf)
