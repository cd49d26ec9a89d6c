"""Load spectra of torque signals: rainflow counts, load-duration distribution and
damage-equivalent loads (numpy and the ``rainflow`` library; docs/virtual.md).

Public API
----------
rainflow_cycles(x)
    Rainflow cycles (ASTM E1049-85): ranges, means, counts.
damage_equivalent_load(cycles, slopes, n_eq)
    ``(Σ nᵢ Sᵢᵐ / N_eq)^(1/m)`` per S–N slope.
load_duration(x, dt, edges)
    Time at level [s] per bin.
range_histogram(cycles, edges)
    Cycles per range bin.
BlockSpectrum(lo, hi, bins, dt), Spectrum, turning_points(x)
    The same spectra of a signal given block by block (its turning points held).
"""

from gbpipe.loads.blockwise import BlockSpectrum, Spectrum, turning_points
from gbpipe.loads.spectra import (
    Cycles,
    damage_equivalent_load,
    load_duration,
    rainflow_cycles,
    range_histogram,
)

__all__ = ["Cycles", "rainflow_cycles", "damage_equivalent_load", "load_duration",
           "range_histogram", "BlockSpectrum", "Spectrum", "turning_points"]
