"""Order tracking: complex amplitudes at exact (also non-integer) orders.

The constant-angle signal (:mod:`gbpipe.harmonics.angle`) is projected on
``exp(-1j m theta)`` for each order ``m``: a DFT evaluated exactly at the order, with no
bin rounding, which matters for non-integer orders such as a planetary mesh (5.3569).
"""

from __future__ import annotations

import numpy as np

from gbpipe.harmonics.angle import angle_map, resample_map_to_angle
from gbpipe.harmonics.checks import as_order, get_window
from gbpipe.harmonics.tacho import AngleMethod

__all__ = ["order_amplitudes"]


def order_amplitudes(
    x: np.ndarray,
    fs: float,
    pulse_times: np.ndarray,
    orders: np.ndarray,
    *,
    pulses_per_rev: int = 1,
    t0: float = 0.0,
    method: AngleMethod = "pchip",
    segments: np.ndarray | None = None,
    window: str | tuple = "hann",
) -> np.ndarray:
    """Order-tracked complex amplitudes at arbitrary orders.

    Each order's amplitude is the Hann-windowed projection of the constant-angle signal
    on ``exp(-1j m theta)``: a DFT evaluated exactly at order ``m`` (no bin rounding,
    which matters for non-integer orders like a mesh at 5.3569). Within a segment of R
    revolutions, orders closer than about 2 / R leak into each other.

    Parameters
    ----------
    x, fs, pulse_times, pulses_per_rev, t0, method
        As in :func:`gbpipe.harmonics.resample_to_angle`.
    orders : array_like, shape (m,)
        Orders [-] (float or Fraction).
    segments : array_like, shape (s, 2), optional
        Angle spans ``[theta_start, theta_end]`` [rad] to analyse separately (e.g. one per
        rpm bin). Default: the whole pulse span.
    window : str or tuple
        Window over each segment.

    Returns
    -------
    numpy.ndarray, complex, shape (s, m) (or (m,) without ``segments``)
        Peak amplitude and phase of ``A cos(m theta + phi)`` -> ``A exp(1j phi)``. NaN for
        segments shorter than 2 revolutions.
    """
    ords = np.array([as_order(o, "orders") for o in np.atleast_1d(orders)], dtype=float)
    x, fs, p, ppr, amap = angle_map(x, fs, pulse_times, pulses_per_rev, method, t0)
    # Orders up to the largest requested need 2 * max samples per rev; use plenty more.
    spr_min = int(np.ceil(8 * ords.max())) + 8
    spr = max(spr_min, 32)
    theta, xa = resample_map_to_angle(x, amap, spr)
    single = segments is None
    seg = (np.array([[0.0, theta[-1]]]) if single
           else np.atleast_2d(np.asarray(segments, dtype=float)))
    out = np.full((seg.shape[0], ords.size), np.nan + 0j)
    for s, (a, b) in enumerate(seg):  # loop over segments (a handful), not cycles
        i0, i1 = np.searchsorted(theta, [a, b])
        if (i1 - i0) < 2 * spr:
            continue
        w = get_window(window, i1 - i0)
        wx = w * xa[i0:i1]
        for c in range(0, ords.size, 16):  # chunks of orders bound the memory
            ph = np.exp(-1j * np.outer(theta[i0:i1], ords[c:c + 16]))
            out[s, c:c + 16] = 2.0 * (wx @ ph) / w.sum()
    return out[0] if single else out
