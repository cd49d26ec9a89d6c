"""Order tracking: complex amplitudes at exact (also non-integer) orders.

The constant-angle signal (:mod:`gbpipe.harmonics.angle`) is projected on
``exp(-1j m theta)`` for each order ``m``: a DFT evaluated exactly at the order, with no
bin rounding, which matters for non-integer orders such as a planetary mesh (5.3569).
"""

from __future__ import annotations

import numpy as np

from gbpipe.harmonics.angle import angle_map, resample_map_to_angle
from gbpipe.harmonics.checks import as_order, as_signal, get_window
from gbpipe.harmonics.tacho import AngleMethod
from gbpipe.units import TWO_PI

__all__ = ["order_amplitudes", "uniform_projection"]


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
    x : array_like, shape (n,) or (n, k)
        Signal, or k signals of one record as columns (they share the angle grid and
        the windows), sample ``i`` at ``t0 + i / fs``.
    fs, pulse_times, pulses_per_rev, t0, method
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
        segments shorter than 2 revolutions. For ``x`` of shape (n, k): shape (s, k, m)
        (or (k, m)), the signals in the order of the columns.
    """
    ords = np.array([as_order(o, "orders") for o in np.atleast_1d(orders)], dtype=float)
    xs = np.asarray(x, dtype=float)
    multi = xs.ndim == 2
    if multi:  # every column checked; the first one carries the angle map's checks
        for j in range(xs.shape[1]):
            as_signal(xs[:, j], f"x[:, {j}]")
    _, fs, p, ppr, amap = angle_map(xs[:, 0] if multi else xs, fs, pulse_times,
                                    pulses_per_rev, method, t0)
    # Orders up to the largest requested need 2 * max samples per rev; use plenty more.
    spr_min = int(np.ceil(8 * ords.max())) + 8
    spr = max(spr_min, 32)
    theta, xa = resample_map_to_angle(xs, amap, spr)
    xa = xa if multi else xa[:, None]
    single = segments is None
    seg = (np.array([[0.0, theta[-1]]]) if single
           else np.atleast_2d(np.asarray(segments, dtype=float)))
    out = np.full((seg.shape[0], xa.shape[1], ords.size), np.nan + 0j)
    step = TWO_PI / spr  # the constant-angle grid is uniform: theta[i] = i * step
    windows: dict[int, np.ndarray] = {}  # by length: segments of one length share theirs
    for s, (a, b) in enumerate(seg):  # loop over segments (a handful), not cycles
        i0, i1 = np.searchsorted(theta, [a, b])
        if (i1 - i0) < 2 * spr:
            continue
        w = windows.get(i1 - i0)
        if w is None:
            w = windows[i1 - i0] = get_window(window, i1 - i0)
        for j in range(xa.shape[1]):
            out[s, j] = (2.0 * uniform_projection(w * xa[i0:i1, j], i0 * step, step, ords)
                         / w.sum())
    out = out if multi else out[:, 0]
    return out[0] if single else out


def uniform_projection(x: np.ndarray, start: float, step: float,
                       orders: np.ndarray) -> np.ndarray:
    """``sum_i x[i] exp(-1j m (start + i step))`` for each order ``m``, exactly.

    The sample index is split as ``i = q B + r`` with ``B ~ sqrt(n)``, so the phasor
    factors into ``exp(-1j m step q B) exp(-1j m step r)``: ``B + n / B`` complex
    exponentials per order instead of ``n``, and the sum becomes one real-by-complex
    matrix product. Each factor is evaluated directly (no recurrence), so the result
    equals the direct sum to rounding.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Samples on a uniform angle grid.
    start, step : float
        Angle of the first sample and the grid step [rad].
    orders : ndarray, shape (m,)
        Orders [-].

    Returns
    -------
    ndarray, complex, shape (m,)
    """
    n = x.size
    block = max(int(np.sqrt(n)), 1)
    n_blocks = -(-n // block)
    xb = np.zeros(n_blocks * block)
    xb[:n] = x
    xb = xb.reshape(n_blocks, block)
    r = np.arange(block) * step
    q = start + np.arange(n_blocks) * (block * step)
    out = np.empty(orders.size, complex)
    for c in range(0, orders.size, 64):  # chunks of orders bound the memory
        o = orders[c:c + 64]
        inner = xb @ np.exp(-1j * np.outer(r, o))          # (n_blocks, orders)
        out[c:c + 64] = np.sum(inner * np.exp(-1j * np.outer(q, o)), axis=0)
    return out
