"""Identification through an order/mode crossing (shared by
tests/harmonics/test_crossing_identification.py and
benchmarks/removal_crossing_identify.py).

The record is the configured ``prbs_speed`` designed test (a PRBS on the speed set-point)
on a tapered ``speed_up`` whose nominal speed and step put a crossing inside the ramp:
``NOMINAL_RPM`` to ``NOMINAL_RPM + STEP_RPM`` at the bench's ramp rate
(``campaign.full_range``: 22 rpm/s), held, and back, so that the 3x HSS line sweeps
through the 62 Hz bench mode (1244 rpm) twice. Removal: ``method_residuals`` with the
regression's configured parameters and the closed-loop bench modes (as rule
``removal_tests``); identification: ``identify_methods`` (as rule ``identify``), with a
held-out window of the record for validation; truth: the model stage's true modes of
each pairing (``model_datasets``), never the identification's own output.

Version ``twin`` is the record's random-only twin (:func:`gbpipe.simulate.random_only`:
the same noise draws, every angle-locked excitation off) identified raw: what the
identification reads from the same noisy record without any line to remove, i.e. the
reference that separates the removal's error from the noise's.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence

import numpy as np

from gbpipe.harmonics import envelope_modes, method_params, method_residuals, test_families
from gbpipe.identify import identify_methods
from gbpipe.model.stage import model_datasets
from gbpipe.simulate import random_only, test

#: Ramp from NOMINAL_RPM by STEP_RPM [rpm]: the 3x HSS order meets 62.2 Hz at 1244 rpm
NOMINAL_RPM = 1200.0
STEP_RPM = 100.0
#: The pairings identified (each direct motor-to-speed path sees the 62 Hz mode)
PAIRINGS = ("Tdrv_to_wdrv", "Tdrn_to_wdrn")
#: The band of the crossed mode [Hz]
BAND = (50.0, 75.0)


def crossing_cfg(cfg: dict, seed: int, pairings: Sequence[str] = PAIRINGS,
                 versions: Sequence[str] = ("clean", "raw", "regression")) -> dict:
    """``cfg`` with the speed ramp through the crossing and the PBSID identification of
    ``pairings`` from ``prbs_speed`` (tapered), in ``versions``."""
    c = copy.deepcopy(cfg)
    c["seed"] = seed
    c["campaign"].update(nominal={**c["campaign"]["nominal"], "speed_rpm": NOMINAL_RPM},
                         step={**c["campaign"]["step"], "speed_rpm": STEP_RPM},
                         settle=2.0, hold=8.0)
    ident = c["identify"]
    ident.update(tests=["prbs_speed"], profiles=["tapered"], methods=["pbsid"],
                 versions=list(versions),
                 pairings=[p for p in ident["pairings"] if p["name"] in pairings])
    return c


def _signals(cfg: dict) -> list[str]:
    # every signal a pairing uses
    names: list[str] = []
    for p in cfg["identify"]["pairings"]:
        names += [n for n in p["inputs"] + p["outputs"] if n not in names]
    return names


def crossed_modes(cfg: dict) -> tuple[dict, dict]:
    """Identify the crossing record of :func:`crossing_cfg` ``cfg``.

    Returns
    -------
    rows : dict
        Per (pairing, version): a list of (true frequency [Hz], true damping ratio [-],
        nearest identified frequency [Hz], its damping ratio [-], status) for each true
        mode of the pairing inside :data:`BAND` (NaN where no mode was identified).
    info : dict
        ``rpm`` (lowest and highest GB1 HSS speed of the record [rpm]), ``samples``.
    """
    truth_cfg = {k: cfg["identify"][k] for k in ("pairings", "frf", "zeta_max")}
    models = model_datasets({k: cfg[k] for k in ("gearbox", "bench", "model")}, truth_cfg)
    truth, bench = models["truth"], models["bench"]
    record = test(cfg, "prbs_speed", "tapered")
    removed = {}
    if "regression" in cfg["identify"]["versions"]:
        fam_cfg = {"gearbox": {"stages": cfg["gearbox"]["stages"]},
                   "excitation": cfg["excitation"], "noise": cfg["noise"],
                   "removal": {"tests": cfg["removal"]["tests"]}}
        families = test_families(fam_cfg)
        params = method_params(cfg["removal"], "regression", families,
                               envelope_modes(bench, cfg["spectra"]))
        removed["regression"] = (method_residuals(
            record, _signals(cfg), "regression", params, families,
            cfg["identify"]["tsa_keep_below"]), None)
    own = [v for v in cfg["identify"]["versions"] if v != "twin"]
    sets = [identify_methods(_versions(cfg, own), record, None, truth, ["pbsid"],
                             removed)["pbsid"]] if own else []
    if "twin" in cfg["identify"]["versions"]:
        twin = test(random_only(cfg), "prbs_speed", "tapered")
        sets.append(identify_methods(_versions(cfg, ["raw"]), twin, None, truth, ["pbsid"],
                                     {})["pbsid"].assign_coords(
            model=lambda d: [str(m).replace("/raw", "/twin") for m in d.model.values]))
    rows = {}
    for ds in sets:
        rows.update(_nearest_modes(ds, truth))
    rpm = record.speed_gb1_hss.values * 60 / (2 * np.pi)
    return rows, {"rpm": (float(rpm.min()), float(rpm.max())),
                  "samples": record.sizes["time"]}


def _versions(cfg: dict, versions: Sequence[str]) -> dict:
    return {**cfg, "identify": {**cfg["identify"], "versions": list(versions)}}


def _nearest_modes(ds, truth) -> dict:
    # per (pairing, version): each true mode in BAND and the nearest identified one
    rows = {}
    for k, name in enumerate(ds.model.values):
        pairing, version = str(name).split("/")
        p = list(truth.pairing.values).index(pairing)
        f_id = ds.mode_identified.values[k]
        z_id = ds.mode_identified_damping.values[k]
        ok = np.isfinite(f_id)
        out = []
        for fj, zj in zip(truth.mode_frequency_true.values[p],
                          truth.mode_damping_true.values[p], strict=True):
            if not BAND[0] <= fj <= BAND[1]:
                continue
            if ok.any():
                i = np.flatnonzero(ok)[np.argmin(np.abs(f_id[ok] - fj))]
                out.append((fj, zj, f_id[i], z_id[i], str(ds.status.values[k])))
            else:
                out.append((fj, zj, np.nan, np.nan, str(ds.status.values[k])))
        rows[(pairing, version)] = out
    return rows
