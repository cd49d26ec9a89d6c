"""Configuration: load, merge, validate against the closed schema, fill in defaults.

Public API
----------
load(path, *overlays)
    YAML file(s) -> merged (as Snakemake's ``--configfile``), validated, complete config.
validate(cfg)
    The same for a merged dict (the Snakefile calls it on Snakemake's ``config``).
merge(base, overlay)
    Deep merge: mappings key by key, lists replaced.
schema()
    The JSON schema (``src/gbpipe/schemas/config.schema.yaml``).
order_bound(cfg)
    States of the bench in the identified band: the default ``identify.max_order``.
model_signal(cfg, name)
    The bench model's name of a record signal (``fit.signals``).
runs(cfg)
    The validated configuration of every run of a study (``runs:``), by name.
fit_prior(cfg)
    The validated configuration a physical fit starts from (``fit.start`` merged).
simulated(cfg)
    True when the campaign is simulated (no ``measured:`` record): the one definition.
measured_specs(cfg), min_duration(cfg)
    The parsed ``measured:`` bench records; the shortest record identification can use.
ConfigError
    Raised for every bad value, naming its key path (``gearbox.stages[1].ring``).

After :func:`load`/:func:`validate` every key that has a default (config/README.md) is
present, so code reads ``cfg["tsa"]["unbiased"]`` without fallbacks.
"""

from __future__ import annotations

from gbpipe.config.bounds import order_bound
from gbpipe.config.derive import Config
from gbpipe.config.fit import model_signal
from gbpipe.config.loader import fit_prior, load, merge, read_yaml, validate
from gbpipe.config.measured import measured_specs, min_duration
from gbpipe.config.schema_validation import SCHEMA_PATH, schema
from gbpipe.config.scope import simulated
from gbpipe.config.study import runs
from gbpipe.errors import ConfigError

__all__ = ["load", "validate", "merge", "schema", "order_bound", "read_yaml", "Config",
           "ConfigError", "SCHEMA_PATH", "measured_specs", "min_duration", "fit_prior",
           "model_signal", "runs", "simulated"]
