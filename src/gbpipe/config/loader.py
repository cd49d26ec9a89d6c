"""Reading, merging and validating a configuration: the one entry point of the package.

``load(path, *overlays)`` gives the same merged dict that Snakemake builds from
``configfile:`` plus ``--configfile`` overlays (mappings merged key by key, lists
replaced), then :func:`validate` makes it complete and checks it, in this order:

0. ``drivetrain: {opentorsion: file.py:function}`` read into the plain description
   (:func:`gbpipe.model.opentorsion_io.expand`, the file relative to the working
   directory), so the schema and the checks below see it like any other;
1. the closed schema, with every number finite and in range, and the schema's defaults
   filled in (:mod:`gbpipe.config.schema_validation`);
2. the gearbox: teeth that assemble and mesh, list lengths per stage, cycle names
   (:mod:`gbpipe.config.gearbox`);
3. the defaults derived from other keys (:mod:`gbpipe.config.derive`);
4. what the records (and designed tests), the harmonic removal, the spectra and the
   identification will need (:mod:`gbpipe.config.records`, :mod:`~gbpipe.config.designed`,
   :mod:`~gbpipe.config.processing`, :mod:`~gbpipe.config.identification`);
5. closed-loop stability of the configured controller gains (:mod:`gbpipe.config.bounds`).

Every error is a :class:`gbpipe.errors.ConfigError` naming the key path, the value and
what would be valid, raised before any stage does real work.
"""

from __future__ import annotations

import copy
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from gbpipe.config import (
    bounds,
    designed,
    drivetrain,
    fit,
    gearbox,
    identification,
    measured,
    processing,
    records,
    virtual,
)
from gbpipe.config.derive import Config, derive
from gbpipe.config.schema_validation import apply_schema
from gbpipe.errors import ConfigError
from gbpipe.model import opentorsion_io

__all__ = ["load", "validate", "merge", "read_yaml", "fit_prior"]


def merge(base: Mapping[str, Any], overlay: Mapping[str, Any]) -> dict[str, Any]:
    """Deep-merge ``overlay`` into a copy of ``base`` (mappings merged, lists replaced).

    This is Snakemake's ``--configfile`` rule, so a config loaded here equals the one a
    workflow run sees. A loaded :class:`~gbpipe.config.derive.Config` enters without its
    derived values, so that validating the result derives them from the overlaid keys.
    """
    out = base.explicit() if isinstance(base, Config) else copy.deepcopy(dict(base))
    for key, value in overlay.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def validate(cfg: Mapping[str, Any], *, check_stability: bool = True) -> Config:
    """Check a merged configuration and return it complete (defaults applied).

    Parameters
    ----------
    cfg : mapping
        The merged configuration (not modified).
    check_stability : bool, default True
        Also refuse PI gains that make the closed-loop bench unstable.

    Returns
    -------
    Config
        A new dict in which every key of the schema with a default is present.

    Raises
    ------
    ConfigError
        Naming the key path, the value and the fix (:class:`gbpipe.errors.UnstableGain`
        for unstable gains).
    """
    cfg = cfg.explicit() if isinstance(cfg, Config) else cfg
    if isinstance(cfg.get("drivetrain"), Mapping):
        cfg = {**cfg, "drivetrain": opentorsion_io.expand(cfg["drivetrain"])}
    out = apply_schema(cfg)
    gearbox.check_gearbox(out)
    gearbox.check_cycle_names(out)
    drivetrain.check_drivetrain(out)
    out = derive(out, bounds.order_bound, bounds.plant_order)
    records.check_campaign(out)
    designed.check_designed(out)
    identification.check_tests(out)
    records.check_sweep(out)
    processing.check_tsa(out)
    processing.check_spectra(out)
    processing.check_removal(out)
    identification.check_identify(out)
    measured.check_measured(out)
    fit.check_fit(out)
    virtual.check_virtual(out)
    if check_stability:
        bounds.check_gains(out)
    if out["fit"]["records"] and out["fit"]["start"]:
        fit_prior(out, check_stability=check_stability)   # a bad start fails here, early
    return out


def fit_prior(cfg: Mapping[str, Any], *, check_stability: bool = True) -> Config:
    """The configuration a physical fit starts from: ``cfg`` with ``fit.start`` merged.

    The records are simulated with ``cfg`` itself; a study sets the bench it simulates in
    ``cfg`` and the nominal bench in ``fit.start`` (docs/fit.md).

    Raises
    ------
    ConfigError
        The merged configuration is invalid; the key path is prefixed with ``fit.start``.
    """
    start = cfg["fit"]["start"]
    prior = merge(cfg, start)
    prior["fit"]["start"] = {}
    try:
        return validate(prior, check_stability=check_stability)
    except ConfigError as exc:
        raise ConfigError(f"fit.start ({exc.field})", exc.problem) from None


def read_yaml(path: str | os.PathLike) -> dict[str, Any]:
    """Read one YAML configuration file (a mapping at the top level)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"config file {path} does not exist")
    with open(path) as fh:
        try:
            data = yaml.safe_load(fh)
        except yaml.YAMLError as exc:
            raise ConfigError("", f"file {path} is not valid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise ConfigError("", f"file {path} must hold a mapping at the top level")
    return data


def load(path: str | os.PathLike, *overlays: str | os.PathLike | Mapping[str, Any],
         check_stability: bool = True) -> Config:
    """Load, merge and validate a configuration file.

    Parameters
    ----------
    path : path-like
        The base YAML file (e.g. ``config/config.yaml``).
    *overlays : path-like or mapping
        Files or dicts deep-merged on top in order (e.g. ``config/ci.yaml``), as
        Snakemake's ``--configfile`` does.
    check_stability : bool, default True
        Refuse unstable controller gains.

    Returns
    -------
    Config
        The complete, validated configuration (a dict).

    Raises
    ------
    FileNotFoundError
        If a file does not exist.
    ConfigError
        If the merged configuration is invalid.
    """
    cfg = read_yaml(path)
    for over in overlays:
        cfg = merge(cfg, over if isinstance(over, Mapping) else read_yaml(over))
    return validate(cfg, check_stability=check_stability)
