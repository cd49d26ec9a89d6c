"""Physical-parameter fit of a torsional chain to identified or measured FRFs, or to a
modal table (docs/fit.md).

The mechanics the fit moves (the chain, its state space, the batched pairing FRFs) live in
:mod:`gbpipe.model`; this package holds what turns data into parameters: key paths into the
config, the free parameters, the weighted residuals, the search, identifiability, the
goodness-of-fit test, the intervals and the stage's dataset.

FrfData, fit_parameters, FitResult
    Fit config parameters (key paths such as ``"gearbox.stiffness[1]"``) to FRFs, with
    95 % intervals and what the data cannot separate.
analyse, design_outputs, Identifiability
    Identifiability from the Jacobian; which added output would separate the parameters.
jackknife_intervals
    95 % intervals from a delete-one-band jackknife over frequency (model error).
fit_record, fit_data, fit_dataset, parameter_unit, assessable_band
    The fit stage: identified FRFs to fit (band, predicted identifiable band, weights),
    and the stage's dataset (rule ``fit``).
ModalData, read_modes_table, modal_fit_dataset
    Fit to a modal table (identified frequencies and damping ratios with spreads).
get_value, overlay
    Config key paths: read one value, and the fitted values as a config overlay.
"""

from __future__ import annotations

from gbpipe.fit.bands import jackknife_intervals
from gbpipe.fit.estimate import FitResult, fit_parameters
from gbpipe.fit.frf_data import FrfData, sigma_from_bounds, sigma_from_coherence
from gbpipe.fit.identifiability import Identifiability, analyse, design_outputs
from gbpipe.fit.keypath import get_value, overlay
from gbpipe.fit.modes import ModalData, read_modes_table
from gbpipe.fit.report import modal_fit_dataset, parameter_unit
from gbpipe.fit.stage import assessable_band, fit_data, fit_dataset, fit_record

__all__ = [
    "FrfData", "sigma_from_coherence", "sigma_from_bounds", "fit_parameters", "FitResult",
    "Identifiability", "analyse", "design_outputs", "fit_data", "fit_dataset",
    "parameter_unit", "jackknife_intervals", "assessable_band", "ModalData",
    "read_modes_table", "modal_fit_dataset", "get_value", "overlay", "fit_record",
]
