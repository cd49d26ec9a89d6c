"""Identification stage: subspace models of the bench from simulated tests vs the true model.

Public API
----------
identify_record(cfg, record, validation, method, tsa_record, tsa_validation)
    Every configured pairing x data version (clean, raw, tsa) of one record, one method.
table_rows(datasets)
    Rows of ``results/tables/identification.csv`` from the stored models.
truth_model(cfg, inputs, outputs)
    The bench model from the same input to the same output, other loop closed.
tsa_dataset(record, names, stages, tsa_cfg, keep_below)
    Measured-like signals after harmonic removal (``tsa_tests`` stage).
"""

from gbpipe.identify.metrics import frf_error_db, match_bandwidth
from gbpipe.identify.prepare import VALIDATION_PARTNER, VERSIONS, condition, decimate
from gbpipe.identify.stage import (
    METHODS,
    identify_record,
    model_matrices,
    settings,
    table_rows,
    tsa_dataset,
)
from gbpipe.identify.truth import true_modes, truth_frf, truth_model

__all__ = ["identify_record", "table_rows", "truth_model", "truth_frf", "true_modes", "tsa_dataset",
           "model_matrices", "settings", "frf_error_db", "match_bandwidth", "condition",
           "decimate", "METHODS", "VERSIONS", "VALIDATION_PARTNER"]
