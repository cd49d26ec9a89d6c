"""Joint removal of several harmonic families by TSA: backfitting of the families'
block-periodic parts (:func:`residual_joint`), or their plain cascade.

Each family is removed by the TSA of :mod:`gbpipe.harmonics.tsa` (same checks, same
averages); this module iterates them. Block averages are projections and the iteration
converges to the residual orthogonal to every family; sliding and quadratic averages are
not, and where their passes stop contracting the residual of the best pass is kept
(:data:`_GROWTH_PASSES`).
"""

from __future__ import annotations

import logging
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Literal

import numpy as np

from gbpipe.harmonics.averaging import CyclePlan
from gbpipe.harmonics.checks import as_count, as_order
from gbpipe.harmonics.least_change import LeastChange
from gbpipe.harmonics.tacho import AngleMethod
from gbpipe.harmonics.tsa import check_averaging, check_band_limit, checked_record, valid_mask
from gbpipe.progress import Progress

log = logging.getLogger(__name__)

__all__ = ["residual_joint", "JointInfo"]

#: Passes of growing change after which the joint iteration of a non-projecting average
#: (sliding, quadratic) is taken to diverge (:func:`residual_joint`).
_GROWTH_PASSES = 3


@dataclass(frozen=True)
class JointInfo:
    """Details of one :func:`residual_joint` call.

    Attributes
    ----------
    synchronous : list of numpy.ndarray
        Synchronous estimate of each family, in the order of ``cycle_orders``.
    valid : numpy.ndarray of bool
        Samples processed by every family.
    iterations : int
        Passes over the families (1 for the cascade).
    converged : bool
        Whether the joint iteration met ``tol``.
    history : list of float
        Change of the residual at each pass, relative to ``||x||``.
    """

    synchronous: list[np.ndarray]
    valid: np.ndarray
    iterations: int
    converged: bool
    history: list[float] = field(default_factory=list)


def residual_joint(
    x: np.ndarray, fs: float, pulse_times: np.ndarray, cycle_orders: Sequence[float | Fraction],
    n_cycles: int | Sequence[int] = 10, pulses_per_rev: int = 1, *,
    mode: Literal["joint", "cascade"] = "joint", max_iter: int = 50, tol: float = 3e-3,
    unbiased: bool = False, band_limit: float | None = 1.0,
    averaging: Literal["block", "sliding", "quadratic"] = "block", t0: float = 0.0,
    method: AngleMethod = "pchip", outside: Literal["keep", "nan"] = "keep",
    return_info: bool = False,
) -> np.ndarray | tuple[np.ndarray, JointInfo]:
    """Remove several harmonic families together.

    A plain cascade (``mode="cascade"``: TSA of family 1, then TSA of family 2 on its
    residual, ...) leaves each family near -20 dB: the family-1 average of N cycles
    also captures about ``|sin(N pi d) / (N sin(pi d))|`` of a family-2 component (d the
    fractional part of the order ratio: 0.11, i.e. -19 dB, for 5.3569 HSS orders over 10
    HSS cycles), which is subtracted as sidebands next to family-1 harmonics (spaced
    ``1/N`` order: block-to-block changes) and never restored.

    ``mode="joint"`` solves ``x = s_1 + ... + s_F + r`` with each ``s_f`` block-periodic
    in its own cycle by block Gauss-Seidel (backfitting): ``s_f = TSA_f(x - sum_{g != f}
    s_g)`` in turn, until a pass changes the residual by less than ``tol * ||x||``.
    As each TSA is (nearly) a projection with ``TSA_f(s_f) = s_f``, this is the cascade
    repeated on its own residual -- alternating projections -- converging to the
    residual orthogonal to all families. On the test sweep (hss + mesh2, noise-free)
    the leftover goes -25 dB (cascade) -> -40 dB after 2 passes -> -47 dB after 9; the
    slow tail comes from near-coincident harmonics (3 x 5.3569 = 16.07 vs HSS order 16,
    closer than the 1/N order resolution of a block).

    Parameters
    ----------
    x, fs, pulse_times, pulses_per_rev, band_limit, t0, method, outside
        As in :func:`residual`.
    cycle_orders : sequence of float or Fraction
        Cycle frequency of each family [HSS orders], each > 0.
    n_cycles : int or sequence of int
        Cycles per block, one value for all families or one per family.
    mode : {"joint", "cascade"}
        Joint iterative removal, or the plain cascade in the given order.
    max_iter : int
        Maximum passes over all families (joint).
    tol : float
        Convergence threshold (joint): stop when a pass changes the residual by less
        than ``tol * ||x||`` (3e-3: -50 dB of the signal).
    unbiased : bool
        Scale the residual by ``sqrt(N / (N - F))`` (F families, common N; with
        different N by ``1 / sqrt(1 - sum 1/N_f)``) to undo the noise-power loss.
    return_info : bool
        Also return a :class:`JointInfo`.

    Returns
    -------
    numpy.ndarray, shape (n,)
        Residual.
    JointInfo
        Only with ``return_info=True``.

    Raises
    ------
    ValueError
        As :func:`residual`, for any family; empty ``cycle_orders``; ``mode`` unknown; a
        joint iteration that diverges without ever changing less than the signal itself.

    Warns
    -----
    UserWarning
        If the joint iteration does not meet ``tol`` in ``max_iter`` passes, or (sliding
        and quadratic averages, which are no projections) its change grows for
        ``_GROWTH_PASSES`` passes in a row: then the residual after the pass of smallest
        change is returned (``JointInfo.iterations`` is that pass).
    """
    if isinstance(cycle_orders, str) or not isinstance(cycle_orders, Sequence | np.ndarray):
        raise TypeError("cycle_orders must be a sequence of floats or Fractions, e.g. "
                        "[1, kin.order('mesh2')]")
    orders = [as_order(c, f"cycle_orders[{i}]") for i, c in enumerate(cycle_orders)]
    if not orders:
        raise ValueError("cycle_orders is empty: give at least one cycle order")
    if mode not in ("joint", "cascade"):
        raise ValueError(f"mode must be 'joint' or 'cascade'; got {mode!r}")
    Ns = list(n_cycles) if isinstance(n_cycles, Sequence | np.ndarray) else [n_cycles] * len(
        orders)
    if len(Ns) != len(orders):
        raise ValueError(f"n_cycles has {len(Ns)} values for {len(orders)} cycle_orders: "
                         f"give one int, or one per family")
    max_iter = as_count(max_iter, "max_iter")
    x, _, amap = checked_record(x, fs, pulse_times, Ns[0], pulses_per_rev, t0, method, outside)
    Ns = [as_count(N, "n_cycles", 2) for N in Ns]
    check_band_limit(band_limit)
    check_averaging(averaging)
    plans = [CyclePlan(amap, c, N, None, band_limit, averaging)
             for c, N in zip(orders, Ns, strict=True)]
    loss = sum(p.self_weight for p in plans)
    if unbiased and loss >= 1:
        raise ValueError(f"unbiased=True needs sum(1/n_cycles) < 1; got {loss:.3g}: use "
                         f"more cycles per block")

    # Both modes work on the residual: r <- (I - P_F) ... (I - P_1) r, accumulating each
    # family's estimate. One pass is the cascade; repeating it is block Gauss-Seidel on
    # x = sum_f s_f + r (because P_f s_f = s_f), i.e. alternating projections, which
    # converges to the residual orthogonal to every family.
    S = [np.zeros(x.size) for _ in plans]
    r = x.copy()
    x_power = max(float(np.sum(x**2)), np.finfo(float).tiny)
    history: list[float] = []
    passes = 1 if mode == "cascade" else max_iter
    converged = mode == "cascade"
    iterations = 0
    best: tuple[np.ndarray, list[np.ndarray]] | None = None
    guard = LeastChange(_GROWTH_PASSES)
    progress = Progress(log, f"joint TSA of {len(plans)} families on {x.size} samples", passes)
    for _ in range(passes):
        iterations += 1
        change = 0.0
        for f, plan in enumerate(plans):
            # Joint: order 0 (per-block mean) is left to the first family only, so that
            # the families do not trade a shared constant back and forth.
            d = plan.synchronous(r, zero_mean=(mode == "joint" and f > 0))[0]
            S[f] += d
            r -= d
            change += float(np.sum(d**2))
        rel = np.sqrt(change / x_power)
        history.append(rel)
        progress(iterations, f"pass changed the residual by {rel:.2g} of the signal "
                 f"(stops below {tol:g})")
        if mode == "joint" and iterations > 1 and rel < tol:
            converged = True
            break
        if mode != "joint" or iterations == 1:
            continue
        # Only block averages are projections. A sliding or quadratic average is a
        # smoother whose pass can amplify some component, so the backfitting may contract
        # for a few passes and then grow geometrically (the soft-coupling sweep's harmonic
        # part: change 0.021, 0.0072, 0.0060, then x1.36 per pass). Keep the iterate after
        # the smallest change; once the change has grown for _GROWTH_PASSES passes in a
        # row, go back to it and stop (a warning below says so).
        if guard.update(rel, iterations):
            best = (r.copy(), [s.copy() for s in S])
        elif guard.diverged(rel, iterations):
            break
    if not converged and best is not None and history[-1] > guard.least:
        (r, S), rel_best, at = best, guard.least, guard.at
        if not rel_best < 1.0:  # not even one pass smaller than the signal: no separation
            raise ValueError(
                f"residual_joint diverged (smallest relative change {rel_best:.2g}, at pass "
                f"{at}): the families' {averaging!r} averages do not separate on this "
                f"record; use averaging 'block' (a projection), or mode 'cascade'")
        warnings.warn(
            f"residual_joint: the {averaging!r} averages do not contract on this record "
            f"(relative change {history[at - 1]:.2g} at pass {at}, then growing to "
            f"{history[-1]:.2g}); the residual after pass {at} is returned. Averaging "
            f"'block' (a projection) converges", UserWarning, stacklevel=2)
        iterations = at
    elif not converged:
        warnings.warn(
            f"residual_joint: not converged after max_iter={max_iter} passes (last "
            f"relative change {history[-1]:.2g} > tol={tol:g}); raise max_iter, or the "
            f"families share harmonics that {Ns}-cycle blocks cannot separate",
            UserWarning, stacklevel=2)
    i_lo, i_hi = plans[0].i_lo, plans[0].i_hi
    if unbiased:
        r[i_lo:i_hi + 1] *= 1.0 / np.sqrt(1.0 - loss)
    valid = valid_mask(x.size, i_lo, i_hi)
    if outside == "nan":
        r[~valid] = np.nan
    if not return_info:
        return r
    return r, JointInfo(S, valid, iterations, converged, history)
