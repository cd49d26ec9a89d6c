"""Configuration: loading, deep-merging, validation against the JSON schema.

``load(path, *overlays)`` gives the same merged dict that Snakemake builds from
``configfile:`` plus ``--configfile`` overlays (mappings merged key by key, lists
replaced), validates it against ``schemas/config.schema.yaml`` and then checks what a
schema cannot say: list lengths that depend on the number of stages, tooth counts,
and the stability of the closed-loop bench with the configured PI gains. Every error
names the field and the fix, and is raised before any stage does real work.
"""

from __future__ import annotations

import copy
import os
import re
from collections.abc import Mapping
from functools import cache
from pathlib import Path
from typing import Any

import yaml

__all__ = ["ConfigError", "load", "validate", "merge", "schema", "SCHEMA_PATH"]

SCHEMA_PATH = Path(__file__).with_name("schemas") / "config.schema.yaml"


class ConfigError(ValueError):
    """A configuration value is missing, of the wrong type or physically impossible."""


@cache
def schema() -> dict[str, Any]:
    """The JSON schema of the configuration, as a dict."""
    with open(SCHEMA_PATH) as fh:
        return yaml.safe_load(fh)


def merge(base: Mapping[str, Any], overlay: Mapping[str, Any]) -> dict[str, Any]:
    """Deep-merge ``overlay`` into a copy of ``base`` (mappings merged, lists replaced).

    This is Snakemake's ``--configfile`` rule, so a config loaded here equals the one a
    workflow run sees.
    """
    out = copy.deepcopy(dict(base))
    for key, value in overlay.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def _field(path: Any) -> str:
    text = ""
    for part in path:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "(top level)"


def _schema_errors(cfg: Mapping[str, Any]) -> None:
    import jsonschema

    validator = jsonschema.Draft202012Validator(schema())
    errors = sorted(validator.iter_errors(cfg), key=lambda e: (len(e.absolute_path), e.path))
    if not errors:
        return
    err = jsonschema.exceptions.best_match(errors)
    field = _field(err.absolute_path)
    desc = err.schema.get("description", "") if isinstance(err.schema, dict) else ""
    if err.validator == "required":
        missing = err.message.split("'")[1] if "'" in err.message else err.message
        where = f"{field}.{missing}" if err.absolute_path else missing
        raise ConfigError(f"config field '{where}' is missing: add it (see config/README.md)")
    if err.validator == "oneOf":
        # e.g. an inertia given as text "6730 kg m2": the oneOf message says nothing useful
        raise ConfigError(
            f"config field '{field}': {err.instance!r} is not valid: expected a positive number"
            f"{' — ' + desc if desc else ''} (units are fixed by the key, not written in the value)"
        )
    hint = f" ({desc.strip()})" if desc else ""
    raise ConfigError(f"config field '{field}': {err.message}{hint}")


def validate(cfg: Mapping[str, Any], *, check_stability: bool = True) -> dict[str, Any]:
    """Validate a configuration dict; return it unchanged as a plain dict.

    Parameters
    ----------
    cfg : mapping
        The merged configuration.
    check_stability : bool, default True
        Also assemble the closed-loop bench and refuse PI gains that make it unstable.

    Raises
    ------
    ConfigError
        Naming the offending field and the fix.
    """
    from gbpipe import kinematics

    cfg = _coerce_numbers(dict(cfg))
    _schema_errors(cfg)
    gb = cfg["gearbox"]
    try:
        stages = kinematics.parse_stages(gb["stages"])
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    n = len(stages)
    if len(gb["inertia"]) != n + 1:
        raise ConfigError(
            f"config field 'gearbox.inertia' has {len(gb['inertia'])} entries; a gearbox with "
            f"{n} stages needs {n + 1} (one per stage group, then the HSS flange) in kg·m²"
        )
    if len(gb["stiffness"]) != n:
        raise ConfigError(
            f"config field 'gearbox.stiffness' has {len(gb['stiffness'])} entries; a gearbox "
            f"with {n} stages needs {n} (the shaft after each stage) in N·m/rad"
        )
    allowed = {"planetary": {"carrier", "planet", "sun"}, "parallel": {"wheel", "pinion"}}
    for i, entry in enumerate(gb["inertia"][:n]):
        if isinstance(entry, Mapping):
            bad = set(entry) - allowed[stages[i].type]
            if bad:
                raise ConfigError(
                    f"config field 'gearbox.inertia[{i}]': unknown member(s) {sorted(bad)} for a "
                    f"{stages[i].type} stage; use {sorted(allowed[stages[i].type])}"
                )
            if sum(entry.values()) <= 0:
                raise ConfigError(f"config field 'gearbox.inertia[{i}]': total inertia must be > 0")
    if isinstance(gb["inertia"][n], Mapping):
        raise ConfigError("config field 'gearbox.inertia[-1]': the HSS flange takes one number")
    model_frf = cfg.get("model", {}).get("frf")
    if model_frf and model_frf["f_min"] >= model_frf["f_max"]:
        raise ConfigError("config field 'model.frf.f_min' must be below 'model.frf.f_max'")
    from gbpipe.simulate.profiles import check_campaign, check_excitation, check_sweep

    check_excitation(cfg)
    _check_cycles(cfg)
    check_campaign(cfg)
    check_sweep(cfg)
    if check_stability:
        from gbpipe.model import check_stability as _check

        _check(cfg)
    return cfg


_FLOAT_RE = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)[eE][+-]?\d+$")


def _coerce_numbers(value: Any) -> Any:
    # PyYAML (YAML 1.1) reads 1.5e8 — no dot, no sign in the exponent — as text. Accept
    # exactly that spelling as a number; any other text stays text and fails validation.
    if isinstance(value, str) and _FLOAT_RE.match(value.strip()):
        return float(value)
    if isinstance(value, Mapping):
        return {k: _coerce_numbers(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_coerce_numbers(v) for v in value]
    return value


def _check_cycles(cfg: Mapping[str, Any]) -> None:
    # every cycle named for TSA must be a shaft, member or mesh of this gearbox
    from gbpipe.kinematics import order_of

    tsa = cfg.get("tsa")
    if not tsa:
        return
    named = [(f"tsa.variants[{i}].cycles", c) for i, v in enumerate(tsa["variants"])
             for c in v["cycles"]]
    names = [v["name"] for v in tsa["variants"]]
    if len(set(names)) != len(names):
        raise ConfigError(f"config field 'tsa.variants': names must be unique, got {names}")
    named += [("tsa.tests", c) for c in tsa["tests"]]
    for field, cycle in named:
        try:
            order_of(cfg["gearbox"]["stages"], cycle)
        except ValueError as exc:
            raise ConfigError(f"config field '{field}': {exc}") from None


def load(path: str | os.PathLike, *overlays: str | os.PathLike | Mapping[str, Any],
         check_stability: bool = True) -> dict[str, Any]:
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
    dict
        The validated configuration.

    Raises
    ------
    FileNotFoundError
        If a file does not exist.
    ConfigError
        If the merged configuration is invalid.
    """
    cfg = _read_yaml(path)
    for over in overlays:
        cfg = merge(cfg, over if isinstance(over, Mapping) else _read_yaml(over))
    return validate(cfg, check_stability=check_stability)


def _read_yaml(path: str | os.PathLike) -> dict[str, Any]:
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"config file {path} does not exist")
    with open(path) as fh:
        try:
            data = yaml.safe_load(fh)
        except yaml.YAMLError as exc:
            raise ConfigError(f"config file {path} is not valid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"config file {path} must hold a mapping at the top level")
    return data
