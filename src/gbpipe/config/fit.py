"""Cross-field checks of the ``fit`` section (physical-parameter fit, docs/fit.md).

The schema checks types and ranges; here: the records, version, method and pairings are
among the identified ones (for a modal-table fit: the table is a file, its system the
plant or a pairing), the band lies in the identification grid, every free key path
names a positive number, the bounds are of free parameters, and the weights have the
bounds they need. The start overlay is validated as a whole configuration by
:func:`gbpipe.config.loader.validate` (it may not import this module's caller).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from gbpipe.config.schema_validation import suggest
from gbpipe.config.scope import simulated
from gbpipe.errors import ConfigError
from gbpipe.fit.keypath import get_value
from gbpipe.model import bench_ss

__all__ = ["check_fit", "model_signal"]


def _among(path: str, value: str, valid: list[str], what: str) -> None:
    if value not in valid:
        raise ConfigError(path, f"'{value}' is not among the {what} {valid}; "
                                f"{suggest(value, valid)}")


def check_fit(cfg: Mapping[str, Any]) -> None:
    """Check the ``fit`` section against the identification it fits.

    Raises
    ------
    ConfigError
        Naming the key (``fit.records[0]``, ``fit.free[2]`` …) and the fix.
    """
    fit, idc = cfg["fit"], cfg["identify"]
    if not fit["records"]:
        return
    if fit["data"] == "modes":
        _check_modes(cfg)
        _check_free(cfg)
        return
    if fit["data"] == "nonparametric" and simulated(cfg):
        raise ConfigError("fit.data", "nonparametric fits a bench record's Welch FRF; a "
                          "simulated record's reference is the true model: map bench "
                          "records (measured:) or set fit.data: frf")
    if not simulated(cfg):
        records, what = list(cfg["measured"]), "bench records (measured:)"
    else:
        records = [f"{t}_{p}" for t in idc["tests"] for p in idc["profiles"]]
        what = "identified records (identify.tests x identify.profiles)"
    for i, r in enumerate(fit["records"]):
        _among(f"fit.records[{i}]", r, records, what)
    _among("fit.version", fit["version"], list(idc["versions"]), "identify.versions")
    _among("fit.method", fit["method"], list(idc["methods"]), "identify.methods")
    if fit["data"] == "frf" and fit["weight"] != "uniform" and not (
            fit["method"] in idc["bounds"]["methods"] and idc["bounds"]["groups"] > 0):
        raise ConfigError("fit.weight", f"'{fit['weight']}' needs the 95 % bounds of the "
                          f"{fit['method']} models: add it to identify.bounds.methods with "
                          "identify.bounds.groups > 0, or set fit.weight: uniform")
    names = [p["name"] for p in idc["pairings"]]
    for i, p in enumerate(fit["pairings"]):
        _among(f"fit.pairings[{i}]", p, names, "identify.pairings")
    _check_signals(cfg)
    if 0 < fit["jackknife"] < 3:
        raise ConfigError("fit.jackknife", f"{fit['jackknife']} bands: use 0 (Fisher "
                          "intervals only) or at least 3")
    lo, hi = fit["band"]
    f_min, f_max = idc["frf"]["f_min"], idc["frf"]["f_max"]
    if not f_min <= lo < hi <= f_max:
        raise ConfigError("fit.band", f"[{lo}, {hi}] Hz must be increasing and inside the "
                          f"identification grid identify.frf [{f_min}, {f_max}] Hz")
    _check_free(cfg)


def _check_modes(cfg: Mapping[str, Any]) -> None:
    """A modal-table fit: the table exists, the system is the plant or a pairing."""
    modes = cfg["fit"]["modes"]
    if not modes.get("file"):
        raise ConfigError("fit.modes.file", "fit.data: modes needs the modal table's path "
                          "(CSV with frequency_hz, damping, frequency_spread_hz, "
                          "damping_spread)")
    made_here = Path(cfg.get("results", "results")) in Path(modes["file"]).parents
    # a table under this run's results folder (e.g. tables/modes_measured.csv) is made by
    # the workflow: Snakemake reports it if no rule does
    if not made_here and not Path(modes["file"]).is_file():
        raise ConfigError("fit.modes.file", f"'{modes['file']}' is not a file (relative to "
                          "the working directory) nor under this run's results folder")
    names = [p["name"] for p in cfg["identify"]["pairings"]]
    _among("fit.modes.system", modes["system"], ["plant", *names],
           "systems (plant or identify.pairings)")
    lo, hi = modes["band"]
    if not lo < hi:
        raise ConfigError("fit.modes.band", f"[{lo}, {hi}] Hz must be increasing")


def _check_free(cfg: Mapping[str, Any]) -> None:
    """Every free key path names a positive bench number; bounds are of free ones."""
    fit = cfg["fit"]
    for i, path in enumerate(fit["free"]):
        # the model is the drivetrain's when one is described, else gearbox + bench
        sections = ("drivetrain.",) if cfg.get("drivetrain") else ("gearbox.", "bench.")
        if not path.startswith(sections):
            raise ConfigError(f"fit.free[{i}]", f"'{path}' is not a number of the bench "
                              f"model: free keys of the {' or '.join(x[:-1] for x in sections)} "
                              "section, "
                              "e.g. " + ("'drivetrain.shafts[0].stiffness'"
                                         if cfg.get("drivetrain") else "'gearbox.stiffness[1]'"))
        try:
            value = get_value(cfg, path)
        except ConfigError as exc:
            raise ConfigError(f"fit.free[{i}]", f"'{path}': {exc.problem}") from None
        if not value > 0:
            raise ConfigError(f"fit.free[{i}]", f"'{path}' is {value}: the fit works on "
                              "log-parameters and needs a prior > 0")
    for path, (b_lo, b_hi) in fit["bounds"].items():
        _among(f"fit.bounds.{path}", path, list(fit["free"]), "free parameters (fit.free)")
        if not b_lo < b_hi:
            raise ConfigError(f"fit.bounds.{path}", f"[{b_lo}, {b_hi}] must be increasing")


def model_signal(cfg: Mapping[str, Any], name: str) -> str:
    """The bench model's name of a record signal (``fit.signals``, else the same)."""
    return cfg["fit"]["signals"].get(name, name)


def _check_signals(cfg: Mapping[str, Any]) -> None:
    """Every signal of a fitted pairing is (or is mapped to) a signal of the bench model."""
    plant = bench_ss(cfg, closed=False)  # the drivetrain's (or the paper's) signals
    outputs = plant.outputs
    motor_inputs = [u for u in plant.inputs if u.startswith("motor_torque_")]
    fit = cfg["fit"]
    for name in fit["pairings"]:
        pairing = next(p for p in cfg["identify"]["pairings"] if p["name"] == name)
        for key, valid in (("inputs", motor_inputs), ("outputs", list(outputs))):
            for s in pairing[key]:
                if model_signal(cfg, s) not in valid:
                    raise ConfigError(f"fit.signals.{s}", f"'{model_signal(cfg, s)}' (pairing "
                                      f"{name}) is not among the bench model's {key} "
                                      f"{valid}: map the record's name to one of them")
