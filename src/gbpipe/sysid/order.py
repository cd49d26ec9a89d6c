"""Model order from the singular values of the subspace step."""

from __future__ import annotations

import numpy as np

from gbpipe.errors import ConfigError

__all__ = ["select_order", "check_order_rank"]


def select_order(s: np.ndarray, max_order: int) -> int:
    """Model order from singular values: the last large gap above the noise floor.

    The log-spectrum of singular values drops at the true order onto a flat noise floor.
    Candidates are the orders whose gap ``log(s[n-1] / s[n])`` is at least half the largest
    gap; the highest candidate is taken, so that a weak second resonance (a smaller gap
    inside the signal part) is not cut off in favour of the strongest one.

    Parameters
    ----------
    s : ndarray
        Singular values, descending.
    max_order : int
        Largest admissible order.

    Returns
    -------
    int
    """
    s = np.asarray(s, dtype=float)
    top = min(max_order, s.size - 1)
    if top < 1:
        return max(1, min(max_order, s.size))
    floor = s[0] * 1e-13  # values at round-off level count as zero
    ls = np.log(np.maximum(s[: top + 1], floor))
    gaps = ls[:-1] - ls[1:]  # gaps[i] = log(s[i] / s[i + 1]): order i + 1
    best = float(gaps.max())
    cand = np.flatnonzero(gaps >= 0.5 * best)
    return int(cand[-1] + 1)


def check_order_rank(s: np.ndarray, order: int) -> None:
    """Refuse an order above the numerical rank of the subspace step's singular values.

    Raises
    ------
    ConfigError
        ``s[order - 1]`` is at round-off level (``<= 1e-14 * s[0]``): the data (e.g. a
        noise-free record of a lower-order system) carry fewer than ``order`` states.
    """
    if s[order - 1] <= s[0] * 1e-14:
        raise ConfigError(
            "order",
            f"order={order} exceeds the rank of the data ({int(np.sum(s > s[0] * 1e-14))}); "
            "lower the order",
        )
