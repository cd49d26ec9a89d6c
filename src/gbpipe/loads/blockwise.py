"""Load spectra of a signal that arrives block by block (hour-long records, issue 47): the
same rainflow cycles, load-duration distribution and damage-equivalent loads as the whole
signal gives (:mod:`gbpipe.loads.spectra`), holding per block only its turning points.

Rainflow counting is not additive over blocks (a cycle closes across them), but it reads
the signal only through its sequence of reversals: each block's turning points (its local
extrema, with its first and last sample kept) are extracted in numpy
(:func:`turning_points`), and the ``rainflow`` library counts their concatenation, whose
reversals are the whole signal's (between two kept points the signal is monotonic, so a
block's edge sample is a reversal of the concatenation exactly when it is one of the
signal). The cycles are the library's on the whole signal, in the same order (tested).
The time at level, with the level bins fixed beforehand, is a sum over blocks
(of sample counts: exact).

Memory: the turning points, about 8 bytes per reversal (a third of the samples of a noisy
measured torque, fewer of a smoothed estimate), instead of the signal.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gbpipe.loads.spectra import (
    Cycles,
    damage_equivalent_load,
    finite_signal,
    load_duration,
    rainflow_cycles,
    range_histogram,
)

__all__ = ["turning_points", "BlockSpectrum", "Spectrum"]


def turning_points(x: np.ndarray) -> np.ndarray:
    """The reversals of ``x`` (the values :func:`rainflow.reversals` gives), its first
    and last sample always among them.

    Parameters
    ----------
    x : ndarray (N,)
        Signal [its unit].

    Returns
    -------
    ndarray
        ``x[0]``, every sample where the signal's slope changes sign (the first of a flat
        run), ``x[-1]``; ``x`` itself if it has two samples or fewer (the library gives
        only the first of two samples, but a block's two are needed in the sequence).
    """
    x = np.asarray(x, dtype=float)
    if x.size <= 2:
        return x.copy()
    # one sample per flat run (the library skips a repeated value), then the sign changes
    runs = x[np.r_[0, np.flatnonzero(np.diff(x) != 0) + 1]]
    d = np.diff(runs)
    # the library's own test, d_last * d_next < 0, not the signs: the same verdicts
    interior = runs[1:-1][d[:-1] * d[1:] < 0]
    return np.concatenate([x[:1], interior, x[-1:]])


@dataclass
class Spectrum:
    """Load spectra of one signal (docs/virtual.md, "Load spectra").

    Attributes
    ----------
    range_centre, cycle_count : ndarray (bins,)
        Rainflow range bins' centres [signal unit] over ``[0, largest range]`` and the
        cycles in each [-] (half cycles count ½).
    level_centre, time_at_level : ndarray (bins,)
        Level bins' centres [signal unit] over ``[min, max]`` of the signal and the time
        spent in each [s].
    del_ : ndarray (n_slopes,)
        Damage-equivalent load range per S–N slope [signal unit], ``N_eq = f_eq T``.
    """

    range_centre: np.ndarray
    cycle_count: np.ndarray
    level_centre: np.ndarray
    time_at_level: np.ndarray
    del_: np.ndarray


def _centres(edges: np.ndarray) -> np.ndarray:
    return 0.5 * (edges[1:] + edges[:-1])


class BlockSpectrum:
    """Load spectra of one signal given block after block, in time order.

    Parameters
    ----------
    lo, hi : float
        Smallest and largest value of the whole signal [its unit]: the load-duration
        bins span them (a constant signal gets a bin 1e-12 wide).
    bins : int
        Bins of the range histogram and of the load-duration distribution [-].
    dt : float
        Sample interval [s].
    """

    def __init__(self, lo: float, hi: float, bins: int, dt: float) -> None:
        self.level_edges = np.linspace(lo, hi if hi > lo else lo + 1e-12, bins + 1)
        self.bins, self.dt = bins, dt
        self._at_level = np.zeros(bins)
        self.samples = 0
        self._turns: list[np.ndarray] = []

    def add(self, x: np.ndarray) -> None:
        """The next block of the signal [its unit] (in time order, after the last).

        Raises
        ------
        ValueError
            ``x`` is not finite.
        """
        x = finite_signal(x)
        # samples per level (whole numbers, summed exactly), times dt at the end
        self._at_level += load_duration(x, 1.0, self.level_edges)
        self._turns.append(turning_points(x))
        self.samples += x.size

    def result(self, slopes: Sequence[float], f_eq: float) -> Spectrum:
        """The spectra of the blocks added: the rainflow count of their turning points,
        which it releases (call it once, after the last block).

        Parameters
        ----------
        slopes : sequence of float
            S–N slopes m [-] of the damage-equivalent loads.
        f_eq : float
            Equivalent frequency [Hz]: ``N_eq = f_eq · samples · dt``.
        """
        turns = np.concatenate(self._turns) if self._turns else np.zeros(0)
        self._turns.clear()
        if turns.size == 2 and self.samples > 2:
            # a monotonic signal: the library counts one half cycle, first to last
            # sample, in it, but none in a series of two samples
            cyc = Cycles(np.abs(np.diff(turns)), np.array([turns.mean()]), np.array([0.5]))
        else:
            cyc = rainflow_cycles(turns)
        top = max(float(cyc.range.max()) if cyc.range.size else 0.0, 1e-12)
        edges = np.linspace(0.0, top, self.bins + 1)
        return Spectrum(_centres(edges), range_histogram(cyc, edges),
                        _centres(self.level_edges), self._at_level * self.dt,
                        damage_equivalent_load(cyc, slopes, f_eq * self.samples * self.dt))
