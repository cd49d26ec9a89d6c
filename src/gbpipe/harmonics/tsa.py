"""Harmonic removal by block time-synchronous averaging (TSA), as in Simcenter Testlab.

:func:`residual` removes one harmonic family: the signal is cut at constant angle into
cycles of a (possibly virtual) tachometer, blocks of ``n_cycles`` consecutive cycles are
averaged, and each block's mean cycle -- the synchronous component: the cycle frequency
and all its harmonics -- is subtracted from every cycle of the block.
:func:`gbpipe.harmonics.joint.residual_joint` removes several families, jointly
(default) or in cascade, with the checks of this module (``checked_record`` ...).

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

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Literal

import numpy as np

from gbpipe.harmonics.angle import AngleMap, angle_map
from gbpipe.harmonics.averaging import AVERAGING, CyclePlan
from gbpipe.harmonics.checks import as_count, as_order
from gbpipe.harmonics.tacho import AngleMethod, check_pulse_times

__all__ = ["residual", "TSAInfo"]


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


def checked_record(x: Any, fs: float, pulse_times: Any, n_cycles: int, pulses_per_rev: int,
                   t0: float, method: AngleMethod, outside: str
                   ) -> tuple[np.ndarray, int, AngleMap]:
    """The checked record, cycles per block and angle map of a TSA call (also
    :func:`gbpipe.harmonics.joint.residual_joint`'s)."""
    n_cycles = as_count(n_cycles, "n_cycles", 2)
    if outside not in ("keep", "nan"):
        raise ValueError(f"outside must be 'keep' or 'nan'; got {outside!r}")
    x, fs, p, ppr, amap = angle_map(x, fs, pulse_times, pulses_per_rev, method, t0)
    # Interval-ratio checks (missing / extra pulses, jitter): refuse, never repair here.
    check_pulse_times(p)
    return x, n_cycles, amap


def check_averaging(averaging: str) -> None:
    """Refuse an averaging that :data:`gbpipe.harmonics.averaging.AVERAGING` lacks."""
    if averaging not in AVERAGING:
        raise ValueError(f"averaging must be 'block', 'sliding' or 'quadratic'; "
                         f"got {averaging!r}")


def check_band_limit(band_limit: float | None) -> None:
    """Refuse a band limit outside (0, 1] of the Nyquist frequency (None: no limit)."""
    if band_limit is not None and not (0.0 < float(band_limit) <= 1.0):
        raise ValueError(f"band_limit must be in (0, 1] (fraction of the Nyquist frequency) "
                         f"or None; got {band_limit!r}")


def valid_mask(n: int, i_lo: int, i_hi: int) -> np.ndarray:
    """Samples ``i_lo .. i_hi`` (the processed span) of ``n``, as a boolean mask."""
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
    x, n_cycles, amap = checked_record(x, fs, pulse_times, n_cycles, pulses_per_rev, t0, method,
                                  outside)
    check_band_limit(band_limit)
    check_averaging(averaging)
    plan = CyclePlan(amap, c, n_cycles, samples_per_cycle, band_limit, averaging)
    s, means = plan.synchronous(x)
    r = x - s
    if unbiased:
        seg = r[plan.i_lo:plan.i_hi + 1]
        w0 = plan.self_weight
        seg *= np.where(plan.partial, 1.0 / np.sqrt(1.0 + w0), 1.0 / np.sqrt(1.0 - w0))
    valid = valid_mask(x.size, plan.i_lo, plan.i_hi)
    if outside == "nan":
        r[~valid] = np.nan
    if not return_info:
        return r
    return r, TSAInfo(s, valid, c, n_cycles, plan.K, plan.n_rows, plan.M, means)
