"""Identification stage: subspace models of the bench from test records vs the true model.

The true FRFs and modes come from the model stage's ``truth.nc`` (data, not model code);
the records after harmonic removal from the ``tsa_tests`` stage
(:func:`gbpipe.harmonics.record_residuals`). See docs/architecture.md, "Stage graph".

Public API
----------
identify_record(cfg, record, validation, truth, method, tsa_record, tsa_validation)
    Every configured pairing x data version (clean, raw, tsa) of one record, one method.
table_rows(datasets)
    Rows of ``results/tables/identification.csv`` from the stored models.
models_dataset, model_matrices
    The identify job's NetCDF, and one stored model back as matrices.
fit_model, validation_fit, reflect_out_of_band
    One subspace fit and its validation fit.
condition, decimate, version_signals
    Records -> identification data.
frf_error_db, match_bandwidth, identified_modes, match_modes
    Identified vs true model.
"""

from gbpipe.identify.dataset import MODE_TOLERANCE, model_matrices, models_dataset
from gbpipe.identify.fitting import METHODS, fit_model, reflect_out_of_band, validation_fit
from gbpipe.identify.metrics import (
    frf_error_db,
    identified_modes,
    match_bandwidth,
    match_modes,
)
from gbpipe.identify.prepare import (
    VALIDATION_PARTNER,
    VERSIONS,
    condition,
    decimate,
    decimation_filter,
    operating_point,
    version_signals,
)
from gbpipe.identify.stage import identify_record, pairing_truth
from gbpipe.identify.table import SHORT, table_rows

__all__ = ["identify_record", "pairing_truth", "table_rows", "models_dataset",
           "model_matrices", "fit_model", "validation_fit", "reflect_out_of_band",
           "condition", "decimate", "decimation_filter", "operating_point", "version_signals",
           "frf_error_db", "match_bandwidth", "identified_modes", "match_modes", "METHODS",
           "VERSIONS", "VALIDATION_PARTNER", "SHORT", "MODE_TOLERANCE"]
