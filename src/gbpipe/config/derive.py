"""Defaults that follow from other keys, materialised at load.

The schema's ``default:`` values are constants. These depend on the rest of the
configuration and are filled in after the schema (only where the key is absent):

* ``tsa.variants[i].averaging`` ← ``tsa.averaging``;
* ``sweep.noise`` ← every level of the top-level ``noise`` not given for the sweep, so
  ``sweep.noise`` is the sweep's complete noise section;
* with ``measured:`` records, ``identify.versions`` ← the listed versions a bench record
  has (:func:`gbpipe.config.measured.bench_versions`: ``raw``, and ``tsa`` where the
  records have a tacho on the paper's gearbox; ``clean`` and the removal methods exist
  only for simulated records), so that the paper campaign's list in
  ``config/config.yaml`` asks nothing of a bench;
* ``identify.tests`` / ``identify.profiles`` ← ``campaign.tests`` / ``campaign.profiles``;
* ``removal.tests`` ← ``tsa.tests`` (the cycles whose families the removal methods take
  off the identified tests);
* ``identify.best`` ← the first configured test, profile, pairing and version;
* ``identify.max_order`` ← :func:`gbpipe.config.bounds.order_bound` (the bench's states in
  the identified band);
* ``identify.order`` ← ``stabilization`` with ``measured:`` records (the order per
  pairing from each record's stabilization diagram), else ``model``;
  ``identify.order: model`` ← :func:`gbpipe.config.bounds.plant_order`, the
  states of the configured open-loop bench in the identified band (24 for the paper's
  bench), so the order follows the gearbox.

The result is a :class:`Config`: a plain dict that remembers which key paths were
derived, so that :func:`gbpipe.config.merge` of a loaded configuration with an overlay
derives them again from the overlaid values instead of keeping stale ones.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from typing import Any

from gbpipe.config.scope import simulated

__all__ = ["Config", "derive"]

Path = tuple[str | int, ...]


class Config(dict):
    """A validated configuration: a dict, plus the key paths of derived values.

    Attributes
    ----------
    derived : frozenset of tuple
        Key paths (e.g. ``("identify", "max_order")``) filled in from other keys.
    """

    derived: frozenset[Path] = frozenset()

    def explicit(self) -> dict[str, Any]:
        """A deep copy without the derived values (what the files and overlays gave)."""
        out = copy.deepcopy(dict(self))
        for path in self.derived:
            node: Any = out
            for key in path[:-1]:
                node = node[key]
            node.pop(path[-1], None)
        return out


def _fill(node: dict, key: str, value: Any, path: Path, derived: set[Path]) -> None:
    if key not in node:
        node[key] = copy.deepcopy(value)
        derived.add((*path, key))


def derive(cfg: dict[str, Any], order_bound: Callable[[Mapping[str, Any]], int],
           plant_order: Callable[[Mapping[str, Any]], int],
           bench_versions: Callable[[Mapping[str, Any]], list[str]]) -> Config:
    """Fill the derived defaults of a schema-complete ``cfg`` (modified in place).

    Parameters
    ----------
    cfg : dict
        Configuration after :func:`gbpipe.config.schema_validation.apply_schema` and the gearbox
        checks.
    order_bound : callable
        ``cfg -> int``, the default of ``identify.max_order``.
    plant_order : callable
        ``cfg -> int``, the order that ``identify.order: model`` stands for.
    bench_versions : callable
        ``cfg -> list``, the versions of ``identify.versions`` bench records have.

    Returns
    -------
    Config
    """
    derived: set[Path] = set()
    tsa = cfg["tsa"]
    for i, v in enumerate(tsa["variants"]):
        _fill(v, "averaging", tsa["averaging"], ("tsa", "variants", i), derived)
    sweep_noise = cfg["sweep"]["noise"]
    for group, levels in cfg["noise"].items():
        if group not in sweep_noise:
            # a whole group derived: an overlay's merge then drops it whole, and the
            # schema's defaults of the group (noise.encoder) cannot stand in for it
            _fill(sweep_noise, group, levels, ("sweep", "noise"), derived)
            continue
        for name, value in levels.items():
            _fill(sweep_noise[group], name, value, ("sweep", "noise", group), derived)
    _fill(cfg["removal"], "tests", list(cfg["tsa"]["tests"]), ("removal",), derived)
    idc = cfg["identify"]
    if not simulated(cfg):
        # not a derived path: the result is the user's list (or a part of it), which a
        # later merge keeps
        idc["versions"] = bench_versions(cfg)
    _fill(idc, "tests", cfg["campaign"]["tests"], ("identify",), derived)
    _fill(idc, "profiles", cfg["campaign"]["profiles"], ("identify",), derived)
    best = idc.setdefault("best", {})
    firsts = {"test": idc["tests"][0], "profile": idc["profiles"][0],
              "pairing": idc["pairings"][0]["name"], "version": idc["versions"][0]}
    for key, value in firsts.items():
        _fill(best, key, value, ("identify", "best"), derived)
    _fill(cfg["fit"], "pairings", [p["name"] for p in idc["pairings"]], ("fit",), derived)
    _fill(cfg["fit"], "band", [idc["frf"]["f_min"], idc["frf"]["f_max"]], ("fit",), derived)
    # fit the first identified designed test (its excitation reaches the torsional modes)
    # with the measured-like data after harmonic removal, when they are identified
    designed_names = [d["name"] for d in cfg["campaign"]["designed"]]
    designed_ids = [t for t in idc["tests"] if t in designed_names]
    _fill(cfg["fit"], "records", [] if not simulated(cfg) or not designed_ids
          else [f"{designed_ids[0]}_{idc['profiles'][0]}"], ("fit",), derived)
    _fill(cfg["fit"], "version", next((v for v in ("regression", "tsa", "raw", "clean")
                                       if v in idc["versions"]), idc["versions"][0]),
          ("fit",), derived)
    if "max_order" not in idc:
        _fill(idc, "max_order", order_bound(cfg), ("identify",), derived)
    # measured records: the order per pairing from their stabilization diagrams; the
    # simulated campaign: the configured bench's states in the band
    _fill(idc, "order", "model" if simulated(cfg) else "stabilization", ("identify",), derived)
    if idc["order"] == "model":
        idc["order"] = plant_order(cfg)
        derived.add(("identify", "order"))
    out = Config(cfg)
    out.derived = frozenset(derived)
    return out
