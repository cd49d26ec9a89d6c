"""Identification stage: subspace models of the bench from test records vs the true model.

The true FRFs and modes come from the model stage's ``truth.nc`` (data, not model code);
the records after harmonic removal from the ``removal_tests`` stage
(:func:`gbpipe.harmonics.record_residuals`). See docs/architecture.md, "Stage graph".

Public API
----------
identify_methods(cfg, record, validation, truth, methods, removed)
    Every configured pairing x data version (clean, raw, tsa, or a removal method) of one
    record, per method (the record conditioned once); ``identify_record`` for one method;
    ``truth`` and ``validation`` None for a measured record (held-out end, nonparametric
    reference).
table_rows(datasets)
    Rows of ``results/tables/identification.csv`` from the stored models.
models_dataset, model_matrices
    The identify job's NetCDF, and one stored model back as matrices.
fit_model, validation_fit, reflect_out_of_band
    One subspace fit and its validation fit.
condition, decimate, version_signals, ConditionedRecord
    Records -> identification data (each signal of each data version conditioned once).
frf_error_db, match_bandwidth, identified_modes, match_modes
    Identified vs reference model.
record_modes, modes_table_rows, group_table_rows
    Stabilization diagrams, modes and model order of a bench record (docs/modal.md):
    every cluster a mode, an order line (harmonic) or noise (spurious), with its
    evidence; the repeats of a group as one row per mode; ``harmonic_bands``,
    ``label_poles``: which poles sit on a shaft-order line.
Reference, truth_reference, nonparametric_reference, within_reference
    What an identified FRF is scored against: the true model (simulated records) or the
    nonparametric FRF of the data with its 95 % bounds (measured records).
"""

from gbpipe.identify.dataset import MODE_TOLERANCE, model_matrices, models_dataset
from gbpipe.identify.design import SOURCES, error_bound_db, predict, predict_test
from gbpipe.identify.fitting import METHODS, fit_model, reflect_out_of_band, validation_fit
from gbpipe.identify.harmonic_lines import (
    HarmonicBands,
    harmonic_bands,
    label_poles,
    record_harmonic_bands,
    shaft_frequency_range,
)
from gbpipe.identify.metrics import (
    frf_error_db,
    identified_modes,
    match_bandwidth,
    match_modes,
)
from gbpipe.identify.modal import TABLE_COLUMNS, modes_table_rows, record_modes
from gbpipe.identify.mode_groups import GROUP_COLUMNS, group_table_rows
from gbpipe.identify.prepare import (
    VALIDATION_PARTNER,
    VERSIONS,
    ConditionedRecord,
    condition,
    decimate,
    decimation_filter,
    operating_point,
    version_signals,
)
from gbpipe.identify.reference import (
    Reference,
    nonparametric_reference,
    truth_reference,
    within_reference,
)
from gbpipe.identify.stage import (
    identify_methods,
    identify_record,
    record_label,
)
from gbpipe.identify.table import SHORT, best_pairings, table_rows

__all__ = ["identify_methods", "identify_record", "record_label", "Reference",
           "truth_reference", "nonparametric_reference", "within_reference", "table_rows",
           "best_pairings", "models_dataset",
           "model_matrices", "fit_model", "validation_fit", "reflect_out_of_band",
           "condition", "ConditionedRecord", "decimate", "decimation_filter", "operating_point",
           "version_signals",
           "frf_error_db", "match_bandwidth", "identified_modes", "match_modes", "METHODS",
           "VERSIONS", "VALIDATION_PARTNER", "SHORT", "MODE_TOLERANCE",
           "SOURCES", "error_bound_db", "predict", "predict_test",
           "record_modes", "modes_table_rows", "TABLE_COLUMNS", "HarmonicBands",
           "harmonic_bands", "label_poles", "record_harmonic_bands", "shaft_frequency_range",
           "GROUP_COLUMNS", "group_table_rows"]
