"""Harmonic removal by block time-synchronous averaging (TSA), as in Simcenter Testlab.

:func:`residual` removes one harmonic family: the signal is cut at constant angle into
cycles of a (possibly virtual) tachometer, blocks of ``n_cycles`` consecutive cycles are
averaged, and each block's mean cycle -- the synchronous component: the cycle frequency
and all its harmonics -- is subtracted from every cycle of the block.
:func:`residual_joint` removes several families, jointly (default) or in cascade.

The cycle is given by ``cycle_order``, its frequency in orders of the tachometer shaft
(HSS): 1 for the HSS itself; for any other shaft or mesh the exact kinematic ratio from
:mod:`gbpipe.kinematics` (stage-2 carrier 609/12960 ~ 0.0470, stage-2 mesh ~ 5.3569), as a
float or :class:`fractions.Fraction`. The virtual tachometer is the HSS angle times
``cycle_order``.

The algorithm (cycle resampling, averages, back to time) and the noise-power loss of
``unbiased`` are in :mod:`gbpipe.harmonics.averaging`; the physics in
docs/architecture.md, "Physics".

Edges. Samples inside the pulse span but after the last complete cycle (a partial
cycle) get the synchronous estimate of the last block (its angle is known). Samples
before the first or after the last pulse have no angle: they are returned unchanged
(``outside="keep"``) or as NaN (``outside="nan"``); ``info.valid`` marks the processed
samples. Trim the record to the pulse span if the edge must be clean.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Literal

import numpy as np

from gbpipe.harmonics.angle import AngleMap, angle_map
from gbpipe.harmonics.averaging import AVERAGING, CyclePlan
from gbpipe.harmonics.checks import as_count, as_order
from gbpipe.harmonics.tacho import AngleMethod, check_pulse_times

__all__ = ["residual", "residual_joint", "synchronous_average", "TSAInfo", "JointInfo"]



@dataclass(frozen=True)
class TSAInfo:
    """Details of one :func:`residual` call.

    Attributes
    ----------
    synchronous : numpy.ndarray, shape (n,)
        Synchronous estimate subtracted from ``x`` (0 outside ``valid``).
    valid : numpy.ndarray of bool, shape (n,)
        Samples inside the pulse span, i.e. processed.
    cycle_order : float
        Cycle frequency [HSS orders].
    n_cycles : int
        Cycles per block (N).
    n_complete_cycles : int
        Complete cycles in the pulse span (K).
    n_blocks : int
        Number of distinct mean cycles (``K // N``, plus one if cycles are left over).
    samples_per_cycle : int
        Angle-domain points per cycle (M).
    mean_cycles : numpy.ndarray, shape (n_blocks, M)
        The block mean cycles (angle domain).
    """

    synchronous: np.ndarray
    valid: np.ndarray
    cycle_order: float
    n_cycles: int
    n_complete_cycles: int
    n_blocks: int
    samples_per_cycle: int
    mean_cycles: np.ndarray


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




def _validate(x, fs, pulse_times, n_cycles, pulses_per_rev, t0, method,
              outside) -> tuple[np.ndarray, int, AngleMap]:
    n_cycles = as_count(n_cycles, "n_cycles", 2)
    if outside not in ("keep", "nan"):
        raise ValueError(f"outside must be 'keep' or 'nan'; got {outside!r}")
    x, fs, p, ppr, amap = angle_map(x, fs, pulse_times, pulses_per_rev, method, t0)
    # Interval-ratio checks (missing / extra pulses, jitter): refuse, never repair here.
    check_pulse_times(p)
    return x, n_cycles, amap


def _check_averaging(averaging: str) -> None:
    if averaging not in AVERAGING:
        raise ValueError(f"averaging must be 'block', 'sliding' or 'quadratic'; "
                         f"got {averaging!r}")


def _check_band_limit(band_limit: float | None) -> None:
    if band_limit is not None and not (0.0 < float(band_limit) <= 1.0):
        raise ValueError(f"band_limit must be in (0, 1] (fraction of the Nyquist frequency) "
                         f"or None; got {band_limit!r}")


def _valid_mask(n: int, i_lo: int, i_hi: int) -> np.ndarray:
    return (np.arange(n) >= i_lo) & (np.arange(n) <= i_hi)


def residual(
    x: np.ndarray,
    fs: float,
    pulse_times: np.ndarray,
    cycle_order: float | Fraction,
    n_cycles: int = 10,
    pulses_per_rev: int = 1,
    *,
    unbiased: bool = False,
    samples_per_cycle: int | None = None,
    band_limit: float | None = 1.0,
    averaging: Literal["block", "sliding", "quadratic"] = "block",
    t0: float = 0.0,
    method: AngleMethod = "pchip",
    outside: Literal["keep", "nan"] = "keep",
    return_info: bool = False,
) -> np.ndarray | tuple[np.ndarray, TSAInfo]:
    """Remove one harmonic family by block time-synchronous averaging.

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal (any unit, e.g. N m), sample ``i`` at ``t0 + i / fs``. Not modified.
    fs : float
        Sample rate [Hz].
    pulse_times : array_like
        Tachometer pulse times of the HSS [s], strictly increasing, within the record,
        without missing/extra pulses (see :func:`gbpipe.harmonics.check_pulse_times`).
    cycle_order : float or fractions.Fraction
        Frequency of the averaged cycle in HSS orders [-], > 0: 1 for the HSS, the
        kinematic ratio for another shaft or a mesh (a mesh cycle is one tooth period).
    n_cycles : int
        Cycles per averaging block (N >= 2; Testlab and the paper use 10).
    pulses_per_rev : int
        Tachometer pulses per HSS revolution.
    unbiased : bool
        Scale the residual by ``sqrt(N / (N - 1))`` so that non-synchronous power
        (noise, resonances) is preserved on average (module notes).
    samples_per_cycle : int, optional
        Angle-domain points per cycle (M). Default: next FFT-friendly size >= 1.25 x
        the most time samples in any cycle (alias-free).
    band_limit : float or None
        Keep harmonics ``h`` of each block's mean cycle with ``h < band_limit * S / 2``,
        S the fewest time samples in any cycle of the block, i.e. below ``band_limit``
        times the Nyquist frequency at the block's highest speed. Higher harmonics of an
        angle-domain mean are interpolation images only; dropping them keeps the
        average an (almost) exact projection. None keeps all M/2 harmonics.
    averaging : {"block", "sliding", "quadratic"}
        ``"block"`` (default): Simcenter Testlab's blocks of ``n_cycles`` cycles, each
        block's mean subtracted from its cycles. ``"sliding"``: every cycle gets the mean
        of the ``n_cycles`` cycles centred on it (clipped at the ends); a linear drift of
        the harmonic's amplitude or phase within the averaging span then cancels, which
        matters for long cycles on a sweep (carrier-2 revolutions span hundreds of HSS
        revolutions). Same cost, same (1 − 1/N) noise-power loss. ``"quadratic"``: every
        cycle gets the value at its own position of a quadratic fitted, point by point of
        the cycle, over the ``n_cycles`` (odd: ``n_cycles + 1`` if even) cycles centred on
        it (Savitzky-Golay across cycles): amplitude and phase may curve within the span,
        as when a harmonic sweeps through a resonance. Noise loses the filter's centre
        weight c0 instead of 1/N (c0 = 0.207 for 11 cycles: −1.0 dB).
    t0 : float
        Time of the first sample [s].
    method : {"pchip", "cubic", "linear"}
        Angle interpolation between pulses (:mod:`gbpipe.harmonics.tacho`).
    outside : {"keep", "nan"}
        Samples outside the pulse span: returned unchanged, or NaN.
    return_info : bool
        Also return a :class:`TSAInfo`.

    Returns
    -------
    numpy.ndarray, shape (n,)
        Residual, in the unit of ``x``.
    TSAInfo
        Only with ``return_info=True``.

    Raises
    ------
    ValueError
        NaN/inf in ``x``; ``fs`` or ``cycle_order`` <= 0; pulse times not increasing,
        with missing/extra pulses or jitter, or outside the record; fewer than
        ``n_cycles`` complete cycles.
    TypeError
        Non-numeric ``cycle_order`` or non-integer counts.
    """
    c = as_order(cycle_order)
    x, n_cycles, amap = _validate(x, fs, pulse_times, n_cycles, pulses_per_rev, t0, method,
                                  outside)
    _check_band_limit(band_limit)
    _check_averaging(averaging)
    plan = CyclePlan(amap, c, n_cycles, samples_per_cycle, band_limit, averaging)
    s, means = plan.synchronous(x)
    r = x - s
    if unbiased:
        seg = r[plan.i_lo:plan.i_hi + 1]
        w0 = plan.self_weight
        seg *= np.where(plan.partial, 1.0 / np.sqrt(1.0 + w0), 1.0 / np.sqrt(1.0 - w0))
    valid = _valid_mask(x.size, plan.i_lo, plan.i_hi)
    if outside == "nan":
        r[~valid] = np.nan
    if not return_info:
        return r
    return r, TSAInfo(s, valid, c, n_cycles, plan.K, plan.n_rows, plan.M, means)


def synchronous_average(x: np.ndarray, fs: float, pulse_times: np.ndarray,
                        cycle_order: float | Fraction, n_cycles: int = 10,
                        pulses_per_rev: int = 1, **kwargs: Any) -> TSAInfo:
    """Block mean cycles and the synchronous estimate, without subtracting.

    Same arguments as :func:`residual` (``unbiased``/``outside``/``return_info`` are
    ignored); returns its :class:`TSAInfo`.
    """
    kwargs = {k: v for k, v in kwargs.items()
              if k not in ("unbiased", "outside", "return_info")}
    _, info = residual(x, fs, pulse_times, cycle_order, n_cycles, pulses_per_rev,
                       return_info=True, **kwargs)
    return info


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
        As :func:`residual`, for any family; empty ``cycle_orders``; ``mode`` unknown.

    Warns
    -----
    UserWarning
        If the joint iteration does not meet ``tol`` in ``max_iter`` passes.
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
    x, _, amap = _validate(x, fs, pulse_times, Ns[0], pulses_per_rev, t0, method, outside)
    Ns = [as_count(N, "n_cycles", 2) for N in Ns]
    _check_band_limit(band_limit)
    _check_averaging(averaging)
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
        if not rel < 1e3:  # diverging (a quadratic fit is no projection): garbage, not a result
            raise ValueError(
                f"residual_joint diverged at pass {iterations} (relative change {rel:.2g}): "
                f"the families' {averaging!r} averages do not separate on this record; use "
                f"averaging 'block' or 'sliding', or mode 'cascade'")
        if mode == "joint" and iterations > 1 and rel < tol:
            converged = True
            break
    if not converged:
        warnings.warn(
            f"residual_joint: not converged after max_iter={max_iter} passes (last "
            f"relative change {history[-1]:.2g} > tol={tol:g}); raise max_iter, or the "
            f"families share harmonics that {Ns}-cycle blocks cannot separate",
            UserWarning, stacklevel=2)
    i_lo, i_hi = plans[0].i_lo, plans[0].i_hi
    if unbiased:
        r[i_lo:i_hi + 1] *= 1.0 / np.sqrt(1.0 - loss)
    valid = _valid_mask(x.size, i_lo, i_hi)
    if outside == "nan":
        r[~valid] = np.nan
    if not return_info:
        return r
    return r, JointInfo(S, valid, iterations, converged, history)
