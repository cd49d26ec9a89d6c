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

Algorithm (all vectorised, O(record length) time and memory):

1. HSS angle of every sample, PCHIP through the pulse angles ``2 pi k / pulses_per_rev``
   (:mod:`gbpipe.orders`); cycle coordinate ``phi = cycle_order * angle / (2 pi)``,
   0 at the first pulse. ``K = floor(phi at the last pulse)`` complete cycles.
2. Each cycle is resampled to ``M`` points at constant angle by cubic B-spline
   interpolation of the samples. ``M`` is at least 1.25 x the largest number of time
   samples in a cycle (slowest speed), so the angle-domain rate exceeds ``fs`` at every
   speed and nothing aliases -- no low-pass needed.
3. Blocks: cycles ``[b N, (b + 1) N)``; the mean cycle of each block. If ``K`` is not a
   multiple of ``N``, the leftover cycles use the mean of the last ``N`` complete
   cycles (which contains them), so every complete cycle is removed by an average of N
   cycles it belongs to. Each mean cycle keeps the harmonics below ``band_limit`` x the
   Nyquist frequency at its block's highest speed (higher ones are interpolation
   images; dropping them keeps the average an almost exact projection).
4. The mean cycles are interpolated back onto the time samples (periodic cubic spline
   in the cycle) -- the *synchronous estimate* -- and subtracted from the original
   ``x``. Subtracting the estimate rather than resampling the residual back avoids a
   round-trip interpolation error on everything that is not removed.

Edges. Samples inside the pulse span but after the last complete cycle (a partial
cycle) get the synchronous estimate of the last block (its angle is known). Samples
before the first or after the last pulse have no angle: they are returned unchanged
(``outside="keep"``) or as NaN (``outside="nan"``); ``info.valid`` marks the processed
samples. Trim the record to the pulse span if the edge must be clean.

Noise-power loss. Anything not synchronous with the cycle (noise, resonances, other
families) is partly captured by the average: with N independent cycles the residual
keeps ``(1 - 1/N)`` of its power, -0.46 dB at N = 10. ``unbiased=True`` scales the
residual by ``sqrt(N / (N - 1))`` (a partial end cycle, which is not in its average,
by ``sqrt(N / (N + 1))``) so that non-synchronous power is preserved on average. For a
joint removal of F families the loss is ``(1 - F/N)`` (the removed subspaces are nearly
orthogonal), corrected by ``sqrt(N / (N - F))``. Two refinements, measured in
docs/tsa.md: the loss applies below the band limit of the mean cycles (``band_limit``),
so on a sweep where a block spans a wide speed range (carrier-2 cycles) white noise
loses a little less; and when the speed changes within a block the captured 1/N
reappears frequency-shifted in the other cycles, so a narrow band (a resonance) can
lose up to ``(1 - 1/N)**2`` (-0.92 dB) while the total stays at ``(1 - 1/N)``.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Literal

import numpy as np
from scipy import fft as sfft
from scipy import ndimage

from gbpipe import orders as _orders

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


class _Plan:
    """Everything about one family that does not depend on the signal values.

    Built once and reused: :func:`residual_joint` applies the same family many times.
    """

    def __init__(self, amap: _orders._AngleMap, cycle_order: float, n_cycles: int,
                 samples_per_cycle: int | None, band_limit: float | None = 1.0,
                 averaging: str = "block") -> None:
        self.n = amap.n
        self.sliding = averaging in ("sliding", "quadratic")
        self.quadratic = averaging == "quadratic"
        self.c = cycle_order
        self.N = n_cycles
        phi_end = cycle_order * amap.theta_end / _orders.TWO_PI
        K = int(np.floor(phi_end + 1e-9))
        if K < n_cycles:
            raise ValueError(
                f"the pulses span only {phi_end:.3f} cycles of cycle_order={cycle_order:.6g} "
                f"(HSS orders) but one block needs n_cycles={n_cycles}: use a longer record, "
                f"or a smaller n_cycles (>= 2)"
            )
        self.K = K
        # Share of a cycle in its own estimate: 1/N for means; the centre weight of the
        # Savitzky-Golay (quadratic) filter over an odd window of N (or N + 1) cycles.
        self.window = n_cycles + (n_cycles % 2 == 0)
        self.self_weight = 1.0 / n_cycles
        if self.quadratic:
            if n_cycles < 4:
                raise ValueError("averaging='quadratic' needs n_cycles >= 4 (a quadratic "
                                 "fit over the cycles of the window)")
            if K < self.window:
                raise ValueError(f"the pulses span only {K} complete cycles but "
                                 f"averaging='quadratic' needs {self.window}: use a longer "
                                 "record or smaller n_cycles")
            from scipy.signal import savgol_coeffs

            self.self_weight = float(savgol_coeffs(self.window, 2)[self.window // 2])
        # Time samples per cycle at the slowest cycle: from the cycle boundary times.
        t_rel = amap.j_lo + np.arange(amap.theta.size)  # sample index of each theta
        phi = amap.theta * (cycle_order / _orders.TWO_PI)
        bounds = np.interp(np.arange(K + 1, dtype=float), phi, t_rel)
        if samples_per_cycle is None:
            M = int(sfft.next_fast_len(int(np.ceil(1.25 * np.max(np.diff(bounds))))))
            M = max(M, 16)
        else:
            M = _orders._as_count(samples_per_cycle, "samples_per_cycle", 8)
        self.M = M
        # Time -> angle: fractional sample index of every grid point, cycles 0..K-1.
        self.grid_pos = amap.grid_positions(M * cycle_order / _orders.TWO_PI, K * M)
        # Block structure: full blocks, plus a tail "block" = last N cycles if needed.
        # Sliding: one mean per cycle, over the N cycles centred on it (clipped at the
        # record ends), so a linear drift of amplitude or phase along the record cancels.
        self.B = K // n_cycles
        self.tail = K > self.B * n_cycles
        self.n_rows = K if self.sliding else self.B + int(self.tail)
        self.start = np.clip(np.arange(K) - n_cycles // 2, 0, K - n_cycles)
        # Highest harmonic each mean cycle keeps: one the time sampling can carry in the
        # block's shortest cycle (h < band_limit * samples/2). Above it an angle-domain
        # mean holds only interpolation images, which would make the average a leaky,
        # non-idempotent projection (it drains near-Nyquist noise in the joint iteration).
        self.keep = None
        if band_limit is not None:
            length = np.diff(bounds)
            if self.sliding:
                windows = np.lib.stride_tricks.sliding_window_view(length, n_cycles)
                shortest = windows.min(axis=1)[self.start]
            else:
                shortest = length[: self.B * n_cycles].reshape(self.B, n_cycles).min(axis=1)
                if self.tail:
                    shortest = np.append(shortest, length[K - n_cycles:].min())
            h_max = np.floor(0.5 * band_limit * shortest)
            self.keep = np.arange(M // 2 + 1)[None, :] <= h_max[:, None]
        # Angle -> time: row (block) and position in the cycle of every valid sample.
        sel = slice(amap.i_lo - amap.j_lo, amap.i_hi - amap.j_lo + 1)
        ph = phi[sel]
        k = np.floor(ph)
        u = (ph - k) * M
        k = k.astype(np.int64)
        if self.sliding:
            row = np.minimum(k, K - 1)
        else:
            row = np.where(k < self.B * n_cycles, k // n_cycles, self.n_rows - 1)
        # Periodic cubic spline via flat padded rows: row r occupies [r (M+3), (r+1)(M+3))
        # with 1 wrapped coefficient before and 2 after, so 4-tap evaluation never leaves
        # its row and one 1-D map_coordinates call serves all blocks.
        self.back_pos = row * (M + 3) + 1.0 + u
        self.i_lo, self.i_hi = amap.i_lo, amap.i_hi
        # Samples of the partial end cycle are not in any average (for `unbiased`).
        self.partial = k >= K

    def mean_cycles(self, x_coef: np.ndarray) -> np.ndarray:
        xa = _orders._evaluate_spline(x_coef, self.grid_pos).reshape(self.K, self.M)
        N, B = self.N, self.B
        if self.quadratic:
            from scipy.signal import savgol_filter

            return savgol_filter(xa, self.window, 2, axis=0, mode="interp")
        if self.sliding:
            csum = np.zeros((self.K + 1, self.M))
            np.cumsum(xa, axis=0, out=csum[1:])
            return (csum[self.start + N] - csum[self.start]) / N
        means = xa[: B * N].reshape(B, N, self.M).mean(axis=1)
        if self.tail:
            means = np.vstack([means, xa[self.K - N:].mean(axis=0)])
        return means

    def synchronous(self, x: np.ndarray, *,
                    zero_mean: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Synchronous estimate at every sample (0 outside the pulse span).

        ``zero_mean`` drops each mean cycle's own mean (order 0).
        """
        means = self.mean_cycles(_orders._spline_coefficients(x))
        if self.keep is not None:
            spec = sfft.rfft(means, axis=1)
            spec *= self.keep
            if zero_mean:
                spec[:, 0] = 0.0
            means = sfft.irfft(spec, n=self.M, axis=1)
        elif zero_mean:
            means -= means.mean(axis=1, keepdims=True)
        coef = ndimage.spline_filter1d(means, order=3, axis=1, mode="grid-wrap")
        padded = np.concatenate([coef[:, -1:], coef, coef[:, :2]], axis=1).ravel()
        s = np.zeros(self.n)
        s[self.i_lo:self.i_hi + 1] = ndimage.map_coordinates(
            padded, self.back_pos[None, :], order=3, prefilter=False, mode="nearest")
        return s, means


def _validate(x, fs, pulse_times, n_cycles, pulses_per_rev, t0, method, outside):
    n_cycles = _orders._as_count(n_cycles, "n_cycles", 2)
    if outside not in ("keep", "nan"):
        raise ValueError(f"outside must be 'keep' or 'nan'; got {outside!r}")
    x, fs, p, ppr, amap = _orders._prepare(x, fs, pulse_times, pulses_per_rev, method, t0)
    # Interval-ratio checks (missing / extra pulses, jitter): refuse, never repair here.
    _orders.check_pulse_times(p)
    return x, n_cycles, amap


def _check_averaging(averaging: str) -> None:
    if averaging not in ("block", "sliding", "quadratic"):
        raise ValueError(f"averaging must be 'block', 'sliding' or 'quadratic'; "
                         f"got {averaging!r}")


def _check_band_limit(band_limit: float | None) -> None:
    if band_limit is not None and not (0.0 < float(band_limit) <= 1.0):
        raise ValueError(f"band_limit must be in (0, 1] (fraction of the Nyquist frequency) "
                         f"or None; got {band_limit!r}")


def _valid_mask(n: int, i_lo: int, i_hi: int) -> np.ndarray:
    valid = np.zeros(n, bool)
    valid[i_lo:i_hi + 1] = True
    return valid


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
    method: _orders.AngleMethod = "pchip",
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
        without missing/extra pulses (see :func:`gbpipe.orders.check_pulse_times`).
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
        Angle interpolation between pulses (:mod:`gbpipe.orders`).
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
    c = _orders._as_order(cycle_order)
    x, n_cycles, amap = _validate(x, fs, pulse_times, n_cycles, pulses_per_rev, t0, method,
                                  outside)
    _check_band_limit(band_limit)
    _check_averaging(averaging)
    plan = _Plan(amap, c, n_cycles, samples_per_cycle, band_limit, averaging)
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


def synchronous_average(
    x: np.ndarray,
    fs: float,
    pulse_times: np.ndarray,
    cycle_order: float | Fraction,
    n_cycles: int = 10,
    pulses_per_rev: int = 1,
    **kwargs,
) -> TSAInfo:
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
    x: np.ndarray,
    fs: float,
    pulse_times: np.ndarray,
    cycle_orders: Sequence[float | Fraction],
    n_cycles: int | Sequence[int] = 10,
    pulses_per_rev: int = 1,
    *,
    mode: Literal["joint", "cascade"] = "joint",
    max_iter: int = 50,
    tol: float = 3e-3,
    unbiased: bool = False,
    band_limit: float | None = 1.0,
    averaging: Literal["block", "sliding", "quadratic"] = "block",
    t0: float = 0.0,
    method: _orders.AngleMethod = "pchip",
    outside: Literal["keep", "nan"] = "keep",
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
    orders = [_orders._as_order(c, f"cycle_orders[{i}]") for i, c in enumerate(cycle_orders)]
    if not orders:
        raise ValueError("cycle_orders is empty: give at least one cycle order")
    if mode not in ("joint", "cascade"):
        raise ValueError(f"mode must be 'joint' or 'cascade'; got {mode!r}")
    Ns = list(n_cycles) if isinstance(n_cycles, Sequence | np.ndarray) else [n_cycles] * len(
        orders)
    if len(Ns) != len(orders):
        raise ValueError(f"n_cycles has {len(Ns)} values for {len(orders)} cycle_orders: "
                         f"give one int, or one per family")
    max_iter = _orders._as_count(max_iter, "max_iter")
    x, _, amap = _validate(x, fs, pulse_times, Ns[0], pulses_per_rev, t0, method, outside)
    Ns = [_orders._as_count(N, "n_cycles", 2) for N in Ns]
    _check_band_limit(band_limit)
    _check_averaging(averaging)
    plans = [_Plan(amap, c, N, None, band_limit, averaging)
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
