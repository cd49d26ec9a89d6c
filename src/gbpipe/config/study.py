"""Many gearboxes or benches in one call: the ``runs:`` list, one results folder each.

A configuration with ``runs:`` is a study: every entry is an overlay (a YAML file, keys
given inline, or both) deep-merged on the configuration without its ``runs:``, exactly as
``--configfile`` would merge it, and run as a workflow of its own whose outputs go to
``<results>/<name>/``. The Snakefile builds one Snakemake module per run from
:func:`runs`, so a study over a hundred configurations is one DAG that a cluster spreads.

Every run is validated here, before any rule is built, and a bad one is named by its
position and name (``runs[2] (stiff_hss): gearbox.stiffness[1]``).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from gbpipe.config.derive import Config
from gbpipe.config.loader import merge, read_yaml, validate
from gbpipe.errors import ConfigError

__all__ = ["runs"]

#: A run's name becomes part of its rule names (``<name>_simulate``) and its folder.
NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
#: Keys of an entry given as a mapping.
ENTRY_KEYS = {"name", "file", "set"}


def _entry(field: str, entry: Any) -> tuple[str, str | None, Mapping[str, Any]]:
    """(name, overlay file or None, inline overlay) of one ``runs:`` entry."""
    if isinstance(entry, str):
        return Path(entry).stem, entry, {}
    if not isinstance(entry, Mapping):
        raise ConfigError(field, f"{entry!r} is neither an overlay file nor a mapping "
                          "{name, file, set}")
    unknown = set(entry) - ENTRY_KEYS
    if unknown:
        raise ConfigError(field, f"unknown key(s) {sorted(unknown)}; an entry has "
                          f"{sorted(ENTRY_KEYS)}")
    if "name" not in entry:
        raise ConfigError(field, "has no `name:` (the run's results folder)")
    inline = entry.get("set", {})
    if not isinstance(inline, Mapping):
        raise ConfigError(f"{field}.set", "must be a mapping of config keys")
    return str(entry["name"]), entry.get("file"), inline


def runs(cfg: Mapping[str, Any]) -> dict[str, Config]:
    """The validated configuration of every run of a study, by name.

    Parameters
    ----------
    cfg : mapping
        The merged configuration; its ``runs`` key lists the overlays (file paths are
        relative to the working directory). ``results`` (default ``"results"``) is the
        folder under which each run gets ``<results>/<name>``.

    Returns
    -------
    dict
        Run name -> complete configuration (:func:`validate` applied) with ``results``
        set to the run's folder and ``runs`` empty; ``{}`` when ``runs`` is absent or
        empty (a single run of ``cfg``).

    Raises
    ------
    ConfigError
        An entry that is malformed, a name that is not an identifier or is used twice,
        an overlay file that is missing or holds ``runs``/``results``, or a merged
        configuration that is invalid (the key path is prefixed with ``runs[i] (name)``).
    """
    entries = cfg.get("runs") or []
    if not entries:
        return {}
    if not isinstance(entries, list):
        raise ConfigError("runs", "must be a list of overlay files or {name, file, set}")
    base = cfg.explicit() if isinstance(cfg, Config) else dict(cfg)
    base.pop("runs")
    results = str(base.get("results", "results")).rstrip("/")
    out: dict[str, Config] = {}
    for i, entry in enumerate(entries):
        field = f"runs[{i}]"
        name, file, inline = _entry(field, entry)
        if not NAME.match(name):
            raise ConfigError(field, f"name {name!r} must start with a letter and hold only "
                              "letters, digits and _ (it names the run's rules and folder); "
                              "give the entry a `name:`")
        if name in out:
            raise ConfigError(field, f"name {name!r} is already used by another run; give "
                              "each run its own `name:`")
        overlay: Mapping[str, Any] = {}
        if file is not None:
            try:
                overlay = read_yaml(file)
            except FileNotFoundError:
                raise ConfigError(field, f"overlay file {file} does not exist (paths are "
                                  "relative to the working directory)") from None
        for layer, what in ((overlay, f"file {file}"), (inline, "set:")):
            nested = {"runs", "results"} & set(layer)
            if nested:
                raise ConfigError(field, f"{what} sets {sorted(nested)}; a run's folder is "
                                  f"{results}/<name> and runs do not nest")
        merged = merge(merge(base, overlay), inline)
        merged["results"] = f"{results}/{name}"
        try:
            out[name] = validate(merged)
        except ConfigError as exc:
            raise ConfigError(f"{field} ({name}): {exc.field}", exc.problem) from None
    return out
