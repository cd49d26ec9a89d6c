"""Load spectra of a torque signal: rainflow cycles, the load-duration distribution and
damage-equivalent loads (docs/virtual.md, "Load spectra").

* Rainflow counting (ASTM E1049-85, the four-point/three-point method) by the ``rainflow``
  library: each cycle's range and mean [N·m] with its count (1 a full cycle, ½ a residual
  half cycle).
* The load-duration distribution (LDD, time at level, IEC 61400-4): the time [s] the
  signal spends in each torque bin.
* The damage-equivalent load of an S–N slope ``m`` (Palmgren–Miner, no endurance limit):
  ``DEL = (Σ nᵢ Sᵢᵐ / N_eq)^(1/m)``, the constant range [N·m] that, repeated ``N_eq``
  times, does the same damage as the counted cycles. ``N_eq = f_eq · T`` with ``T`` the
  record's duration [s] and ``f_eq`` an equivalent frequency [Hz] (1 Hz: the wind
  industry's "1 Hz DEL", comparable between records of any length; a fixed ``N_eq`` such
  as 1e7 scales it by ``(f_eq T / 1e7)^(1/m)``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import rainflow

__all__ = ["Cycles", "rainflow_cycles", "damage_equivalent_load", "load_duration",
           "range_histogram", "finite_signal"]


@dataclass
class Cycles:
    """Rainflow cycles of a signal.

    Attributes
    ----------
    range, mean : ndarray
        Range (peak to valley) and mean of each cycle [signal unit].
    count : ndarray
        1 for a full cycle, 0.5 for a half cycle [-].
    """

    range: np.ndarray
    mean: np.ndarray
    count: np.ndarray


def finite_signal(x: np.ndarray) -> np.ndarray:
    """``x`` as float64, refused if it holds NaN or inf (rainflow counts finite series).

    Raises
    ------
    ValueError
        ``x`` is not finite.
    """
    x = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(x)):
        raise ValueError("the signal holds NaN or inf: rainflow needs a finite series")
    return x


def rainflow_cycles(x: np.ndarray) -> Cycles:
    """Rainflow cycles of ``x`` (ASTM E1049-85, the ``rainflow`` library).

    Parameters
    ----------
    x : ndarray (N,)
        Signal [its unit], finite.

    Raises
    ------
    ValueError
        ``x`` is not finite.
    """
    x = finite_signal(x)
    # straight into one (k, 3) array: a list of k tuples would hold ~150 B per cycle
    c = np.fromiter((cyc[:3] for cyc in rainflow.extract_cycles(x)),
                    dtype=np.dtype((float, 3)))
    return Cycles(c[:, 0], c[:, 1], c[:, 2])


def damage_equivalent_load(cycles: Cycles, slopes: Sequence[float], n_eq: float
                           ) -> np.ndarray:
    """Damage-equivalent range [signal unit] for each S–N slope ``m`` of ``slopes``.

    Parameters
    ----------
    cycles : Cycles
    slopes : sequence of float
        Wöhler exponents m [-] (e.g. 3–5 for welds and shafts, 8–10 for gear teeth).
    n_eq : float
        Equivalent number of cycles [-] (``f_eq · T``, or a fixed 1e7).
    """
    out = []
    for m in slopes:
        total = np.sum(cycles.count * cycles.range ** m)
        out.append((total / n_eq) ** (1.0 / m))
    return np.array(out)


def load_duration(x: np.ndarray, dt: float, edges: np.ndarray) -> np.ndarray:
    """Time at level [s]: the time ``x`` spends in each bin of ``edges`` (LDD).

    Parameters
    ----------
    x : ndarray (N,)
        Signal, each sample held for ``dt`` [s].
    dt : float
        Sample interval [s].
    edges : ndarray (n_bins + 1,)
        Increasing bin edges [signal unit]; samples outside count in no bin.
    """
    counts, _ = np.histogram(x, bins=edges)
    return counts * dt


def range_histogram(cycles: Cycles, edges: np.ndarray) -> np.ndarray:
    """Cycles [-] per range bin of ``edges`` (half cycles count ½)."""
    counts, _ = np.histogram(cycles.range, bins=edges, weights=cycles.count)
    return counts
