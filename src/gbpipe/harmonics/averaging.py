"""One harmonic family's cycle plan: the angle grid of its cycles and their averages.

A :class:`CyclePlan` holds everything about one family on one record that does not depend
on the signal values, so that :func:`gbpipe.harmonics.joint.residual_joint` can apply the same
family many times. The steps (all vectorised, O(record length) time and memory):

1. Cycle coordinate ``phi = cycle_order * angle / (2 pi)``, 0 at the first pulse, from the
   record's :class:`~gbpipe.harmonics.angle.AngleMap`; ``K = floor(phi at the last pulse)``
   complete cycles.
2. Each cycle is resampled to ``M`` points at constant angle by cubic B-spline
   interpolation of the samples. ``M`` is at least 1.25 x the largest number of time
   samples in a cycle (slowest speed), so the angle-domain rate exceeds ``fs`` at every
   speed and nothing aliases -- no low-pass needed.
3. Averages (:data:`AVERAGING`): ``"block"`` -- cycles ``[b N, (b + 1) N)`` share their
   block's mean; if ``K`` is not a multiple of ``N``, the leftover cycles use the mean of
   the last ``N`` complete cycles (which contains them). ``"sliding"`` -- every cycle gets
   the mean of the N cycles centred on it (clipped at the record ends). ``"quadratic"`` --
   a Savitzky-Golay quadratic across the cycles of a centred window. Each mean cycle keeps
   the harmonics below ``band_limit`` x the Nyquist frequency at its block's highest speed
   (higher ones are interpolation images; dropping them keeps the average an almost exact
   projection).
4. The mean cycles are interpolated back onto the time samples (periodic cubic spline
   in the cycle): the *synchronous estimate*, which the caller subtracts from ``x``.
   Subtracting the estimate rather than resampling the residual back avoids a round-trip
   interpolation error on everything that is not removed.

Noise-power loss. Anything not synchronous with the cycle (noise, resonances, other
families) is partly captured by the average: with N independent cycles the residual
keeps ``(1 - 1/N)`` of its power, -0.46 dB at N = 10. ``unbiased=True`` scales the
residual by ``sqrt(N / (N - 1))`` (a partial end cycle, which is not in its average,
by ``sqrt(N / (N + 1))``) so that non-synchronous power is preserved on average. For a
joint removal of F families the loss is ``(1 - F/N)`` (the removed subspaces are nearly
orthogonal), corrected by ``sqrt(N / (N - F))``. Two refinements, measured in
docs/harmonics.md: the loss applies below the band limit of the mean cycles (``band_limit``),
so on a sweep where a block spans a wide speed range (carrier-2 cycles) white noise
loses a little less; and when the speed changes within a block the captured 1/N
reappears frequency-shifted in the other cycles, so a narrow band (a resonance) can
lose up to ``(1 - 1/N)**2`` (-0.92 dB) while the total stays at ``(1 - 1/N)``.
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sfft
from scipy import ndimage
from scipy.signal import savgol_coeffs, savgol_filter

from gbpipe.harmonics.angle import AngleMap, evaluate_spline, spline_coefficients
from gbpipe.harmonics.checks import as_count
from gbpipe.units import TWO_PI

__all__ = ["AVERAGING", "CyclePlan"]

#: The averaging variants of a cycle plan.
AVERAGING = ("block", "sliding", "quadratic")


class CyclePlan:
    """Everything about one family on one record that does not depend on the signal.

    Parameters
    ----------
    amap : AngleMap
        The record's angle map.
    cycle_order : float
        Cycle frequency [orders of the tachometer shaft], > 0.
    n_cycles : int
        Cycles per average (N >= 2).
    samples_per_cycle : int or None
        Angle-domain points per cycle (M); None: alias-free default (module notes).
    band_limit : float or None
        Share of the Nyquist frequency kept by each mean cycle; None keeps all.
    averaging : {"block", "sliding", "quadratic"}
        See :data:`AVERAGING` and :func:`gbpipe.harmonics.tsa.residual`.

    Attributes
    ----------
    K : int
        Complete cycles in the pulse span.
    M : int
        Angle-domain points per cycle.
    n_rows : int
        Distinct mean cycles.
    self_weight : float
        Share of a cycle in its own estimate (1/N; the centre weight for "quadratic"):
        the noise-power loss of the removal.
    i_lo, i_hi : int
        First and last sample inside the pulse span.
    partial : numpy.ndarray of bool
        Samples of ``[i_lo, i_hi]`` after the last complete cycle (in no average).

    Raises
    ------
    ValueError
        Fewer complete cycles than one average needs.
    """

    def __init__(self, amap: AngleMap, cycle_order: float, n_cycles: int,
                 samples_per_cycle: int | None, band_limit: float | None = 1.0,
                 averaging: str = "block") -> None:
        self.n = amap.n
        self.sliding = averaging in ("sliding", "quadratic")
        self.quadratic = averaging == "quadratic"
        self.c = cycle_order
        self.N = n_cycles
        phi_end = cycle_order * amap.theta_end / TWO_PI
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
            self.self_weight = float(savgol_coeffs(self.window, 2)[self.window // 2])
        # Time samples per cycle at the slowest cycle: from the cycle boundary times.
        t_rel = amap.j_lo + np.arange(amap.theta.size)  # sample index of each theta
        phi = amap.theta * (cycle_order / TWO_PI)
        bounds = np.interp(np.arange(K + 1, dtype=float), phi, t_rel)
        if samples_per_cycle is None:
            M = int(sfft.next_fast_len(int(np.ceil(1.25 * np.max(np.diff(bounds))))))
            M = max(M, 16)
        else:
            M = as_count(samples_per_cycle, "samples_per_cycle", 8)
        self.M = M
        # Time -> angle: fractional sample index of every grid point, cycles 0..K-1.
        self.grid_pos = amap.grid_positions(M * cycle_order / TWO_PI, K * M)
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
        # its row and one 1-D spline evaluation serves all blocks.
        self.back_pos = row * (M + 3) + 1.0 + u
        self.i_lo, self.i_hi = amap.i_lo, amap.i_hi
        # Samples of the partial end cycle are not in any average (for `unbiased`).
        self.partial = k >= K

    def mean_cycles(self, x_coef: np.ndarray) -> np.ndarray:
        """Mean cycle of every row, shape (n_rows, M), from the spline coefficients of
        ``x`` (:func:`~gbpipe.harmonics.angle.spline_coefficients`)."""
        xa = evaluate_spline(x_coef, self.grid_pos).reshape(self.K, self.M)
        N, B = self.N, self.B
        if self.quadratic:
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
        means = self.mean_cycles(spline_coefficients(x))
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
        s[self.i_lo:self.i_hi + 1] = evaluate_spline(padded, self.back_pos)
        return s, means
