"""Cross-field checks of the ``identify`` section, against the records it will get.

The subspace methods (:mod:`gbpipe.sysid`) refuse, per job and after the simulation, a
``past`` window shorter than ``future``, an order above the rank the windows allow, or a
record shorter than the data matrix; and a pairing naming a signal no record holds fails
every row. All of it is known from the configuration, so it is refused here, at load.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from gbpipe.config.schema_validation import suggest
from gbpipe.config.scope import simulated
from gbpipe.errors import ConfigError
from gbpipe.model.chain import build_chain
from gbpipe.model.truth import TORQUES
from gbpipe.simulate import base_test, test_names
from gbpipe.simulate.chain_campaign import chain_signals
from gbpipe.simulate.profiles import test_duration
from gbpipe.simulate.signals import SIGNALS

__all__ = ["DECIMATION_TRANSIENT", "decimated_samples", "min_samples", "check_tests",
           "check_identify"]

#: Output samples the anti-aliasing filter's start-up transient takes from a decimated
#: record (a 40-taps-per-factor FIR: one filter length, 40 samples after decimation).
DECIMATION_TRANSIENT = 40


def decimated_samples(cfg: Mapping[str, Any], test: str, profile: str) -> int:
    """Samples of one test record after decimation to ``identify.sample_rate``."""
    fs = float(cfg["campaign"]["sample_rate"])
    q = round(fs / float(cfg["identify"]["sample_rate"]))
    n = round(test_duration(cfg["campaign"], base_test(cfg, test), profile) * fs)
    return max(0, n // q - (DECIMATION_TRANSIENT if q > 1 else 0))


def min_samples(method: str, past: int, future: int, channels: int) -> int:
    """Shortest record [samples] a method's data matrix needs (as :mod:`gbpipe.sysid`).

    PBSID regresses on ``past + 1`` lags of every channel; MOESP and N4SID stack ``past +
    future`` lags. Either needs more windows than columns.
    """
    if method == "pbsid":
        return past + (past + 1) * channels + 1
    return past + future + (past + future) * channels


def _check_rates(cfg: Mapping[str, Any]) -> None:
    idc, camp = cfg["identify"], cfg["campaign"]
    fs, fs_id = float(camp["sample_rate"]), float(idc["sample_rate"])
    ratio = fs / fs_id
    if fs_id > fs or abs(ratio - round(ratio)) > 1e-9 * ratio:
        divisors = [fs / k for k in range(1, 21) if fs / k >= 100 and (fs / k).is_integer()]
        raise ConfigError("identify.sample_rate", f"{fs_id:g} Hz must divide "
                          f"campaign.sample_rate ({fs:g} Hz) by an integer factor; e.g. "
                          f"{', '.join(f'{d:g}' for d in divisors[:6])} Hz")
    fr = idc["frf"]
    if fr["f_min"] >= fr["f_max"]:
        raise ConfigError("identify.frf.f_min", f"{fr['f_min']:g} Hz must be below "
                          f"identify.frf.f_max ({fr['f_max']:g} Hz)")
    f_pass = idc["lowpass"] * fs_id / 2
    if fr["f_max"] > f_pass:
        raise ConfigError("identify.frf.f_max", f"{fr['f_max']:g} Hz is above the "
                          f"anti-aliasing pass band (identify.lowpass × sample_rate / 2 = "
                          f"{f_pass:g} Hz): nothing is identified there; use at most "
                          f"{f_pass:g} Hz or raise identify.sample_rate")
    if camp["settle"] * fs < 10:
        raise ConfigError("campaign.settle", f"{camp['settle']:g} s holds "
                          f"{camp['settle'] * fs:.0f} samples; the operating point subtracted "
                          f"before identification is their mean: use at least {10 / fs:g} s")


def _check_pairings(cfg: Mapping[str, Any]) -> None:
    idc = cfg["identify"]
    names = [p["name"] for p in idc["pairings"]]
    # the record contract: a drivetrain's sensors and motor torques, else the paper's
    if cfg.get("drivetrain") and simulated(cfg):
        chain = build_chain(cfg["drivetrain"])
        signals, torques = list(chain_signals(chain)), [m.input for m in chain.motors]
        where = "drivetrain"
    else:
        signals, torques, where = list(SIGNALS), list(TORQUES), "bench"
    for i, p in enumerate(idc["pairings"]):
        if p["name"] in names[:i]:
            raise ConfigError(f"identify.pairings[{i}].name",
                              f"'{p['name']}' is used twice; pairing names must be unique")
        if not simulated(cfg):
            continue  # names are checked against the measured records (config.measured)
        for j, inp in enumerate(p["inputs"]):
            if inp not in torques:
                raise ConfigError(f"identify.pairings[{i}].inputs[{j}]",
                                  f"'{inp}' is not a motor torque of the simulated "
                                  f"{where}; {suggest(inp, torques)}")
        if "reference" in p:
            raise ConfigError(f"identify.pairings[{i}].reference", "is for measured records "
                              "only (a simulated record's model is scored against the truth)")
        for j, out in enumerate(p["outputs"]):
            if out not in signals:
                raise ConfigError(f"identify.pairings[{i}].outputs[{j}]",
                                  f"'{out}' is not a recorded signal of the simulated "
                                  f"{where}; {suggest(out, signals)}")
    if not simulated(cfg):
        return  # tests, profiles and best.* are of the simulated campaign
    if any(v != "clean" for v in idc["versions"]) and not cfg["campaign"]["measured_like"]:
        raise ConfigError("campaign.measured_like", "is false but identify.versions "
                          f"{idc['versions']} needs measured-like records ('raw', 'tsa'); set "
                          "it true or identify the 'clean' version only")
    choices = {"test": idc["tests"], "profile": idc["profiles"], "pairing": names,
               "version": idc["versions"]}
    for key, valid in choices.items():
        if idc["best"][key] not in valid:
            raise ConfigError(f"identify.best.{key}", f"'{idc['best'][key]}' is not among "
                              f"the configured ones; {suggest(idc['best'][key], valid)}")


def _check_stabilization(cfg: Mapping[str, Any]) -> None:
    # identify.order: stabilization and the order ranges of identify.stabilization
    idc = cfg["identify"]
    st = idc["stabilization"]
    if idc["order"] == "stabilization" and simulated(cfg):
        raise ConfigError("identify.order", "stabilization takes each bench record's order "
                          "from its stabilization diagram, and there are no measured: "
                          "records; for the simulated campaign use model, auto or an integer")
    lo, hi = st["orders"]
    if lo + st["step"] > hi:
        raise ConfigError("identify.stabilization.orders", f"[{lo}, {hi}] with step "
                          f"{st['step']} gives fewer than two orders: a diagram compares "
                          f"consecutive orders; use an upper order >= {lo + st['step']}")
    lo, hi = st["lscf_orders"]
    # LSCF's denominator of order n needs more Welch lines than coefficients
    lines = int(float(idc["nonparametric"]["segment"]) * float(idc["sample_rate"]) / 2)
    if lo >= hi or hi + 1 >= lines:
        raise ConfigError("identify.stabilization.lscf_orders", f"[{lo}, {hi}] must rise and "
                          f"stay below the {lines} Welch lines of identify.nonparametric."
                          f"segment = {idc['nonparametric']['segment']:g} s at "
                          f"{idc['sample_rate']:g} Hz; use lscf_orders[1] <= {lines - 2}")


def _check_horizons(cfg: Mapping[str, Any]) -> None:
    # of every identification, simulated or bench records: the windows and the order
    idc = cfg["identify"]
    past, fut = int(idc["past"]), int(idc["future"])
    if past < fut:
        raise ConfigError("identify.past", f"{past} samples is shorter than identify.future "
                          f"({fut}): every method needs past >= future; use past >= {fut}")
    n_out = min(len(p["outputs"]) for p in idc["pairings"])
    order = idc["order"]
    for method in idc["methods"]:
        # PBSID's observability matrix has `future` block rows; MOESP/N4SID use one less
        # for shift invariance. The narrowest pairing bounds the order.
        rows = fut if method == "pbsid" else fut - 1
        if isinstance(order, int) and order > rows * n_out:
            raise ConfigError("identify.order", f"{order} exceeds what {method} can identify "
                              f"with future = {fut} and {n_out} output(s): at most "
                              f"{rows * n_out}; lower the order or raise identify.future")


def _check_windows(cfg: Mapping[str, Any]) -> None:
    # the simulated records' lengths against the windows
    idc = cfg["identify"]
    past, fut = int(idc["past"]), int(idc["future"])
    channels = max(len(p["inputs"]) + len(p["outputs"]) for p in idc["pairings"])
    tests = [(t, p) for t in idc["tests"] for p in idc["profiles"]]
    have, test, profile = min((decimated_samples(cfg, t, p), t, p) for t, p in tests)
    for method in idc["methods"]:
        need = min_samples(method, past, fut, channels)
        if have < need:
            raise ConfigError("identify.past", f"past = {past}, future = {fut} with {channels} "
                              f"channels need {need} samples for {method}, but the {test} "
                              f"({profile}) record has {have} at {idc['sample_rate']:g} Hz; "
                              "shorten the windows or lengthen campaign.hold")
    groups = int(idc["bounds"]["groups"])
    for method in (m for m in idc["bounds"]["methods"] if m in idc["methods"] and groups):
        need = min_samples(method, past, fut, channels)
        if have // groups < need:
            raise ConfigError("identify.bounds.groups", f"{groups} groups of the {test} "
                              f"({profile}) record hold {have // groups} samples each, but "
                              f"{method} needs {need}; use at most {max(have // need, 0)} "
                              "groups (0: no bounds)")
    shortest = min(test_duration(cfg["campaign"], base_test(cfg, t), p) for t, p in tests)
    if idc["fit_segment"] > shortest:
        raise ConfigError("identify.fit_segment", f"{idc['fit_segment']:g} s is longer than "
                          f"the shortest validation record ({shortest:g} s)")


def check_tests(cfg: Mapping[str, Any]) -> None:
    """Every identified test is a ramp test or a designed test of the campaign (checked
    before anything derives a length or a revolution count from it)."""
    if not simulated(cfg):
        return
    known = test_names(cfg)
    for i, t in enumerate(cfg["identify"]["tests"]):
        if t not in known:
            raise ConfigError(f"identify.tests[{i}]", f"'{t}' is neither a ramp test of "
                              f"campaign.tests nor a campaign.designed name; {suggest(t, known)}")


def check_identify(cfg: Mapping[str, Any]) -> None:
    """Check rates, grid, pairings, windows and order of the ``identify`` section.

    With ``measured`` records, the record-dependent checks are
    :func:`gbpipe.config.measured.check_measured`'s (lengths: when the record is read).
    """
    if simulated(cfg):
        _check_rates(cfg)
    _check_pairings(cfg)
    _check_stabilization(cfg)
    _check_horizons(cfg)
    if simulated(cfg):
        _check_windows(cfg)
