"""The identification stage: every pairing x data version of one record with one method.

:func:`identify_record` fits the models of one job (test, profile, method) and compares
each with the true FRF and modes of its pairing, read from the model stage's
``truth.nc`` (:func:`gbpipe.model.truth_dataset`): identification depends on data, not on
the model code, and runs unchanged on a measured record (docs/architecture.md, "Stage
graph"). A row whose fit raises, or whose validation fit is not finite, is a failure;
a job whose rows all fail raises :class:`gbpipe.errors.StageError`.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.errors import DataError, StageError
from gbpipe.identify.dataset import models_dataset
from gbpipe.identify.fitting import METHODS, fit_model, validation_fit
from gbpipe.identify.metrics import frf_error_db, identified_modes, match_bandwidth, match_modes
from gbpipe.identify.prepare import condition, version_signals

__all__ = ["identify_record", "pairing_truth"]

log = logging.getLogger("gbpipe")


def pairing_truth(truth: xr.Dataset, pairing: Mapping[str, Any]
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """True FRF and modes of one pairing from the model stage's ``truth.nc``.

    Returns
    -------
    g_true : ndarray, shape (n_freq, n_outputs, n_inputs), complex
    freq_hz, zeta : ndarray
        True modes in the band (NaN padding removed).

    Raises
    ------
    gbpipe.errors.DataError
        The pairing is not in ``truth`` or its signals differ (a stale truth file).
    """
    name, ins, outs = pairing["name"], list(pairing["inputs"]), list(pairing["outputs"])
    if name not in truth.pairing.values:
        raise DataError("truth.nc", f"has no pairing '{name}' (it holds "
                        f"{list(truth.pairing.values)}): rerun the model stage")
    sel = truth.sel(pairing=name)
    t_ins = [str(x) for x in sel.input_name.values[:len(ins)]]
    t_outs = [str(x) for x in sel.output_name.values[:len(outs)]]
    if t_ins != ins or t_outs != outs:
        raise DataError("truth.nc", f"pairing '{name}' is {t_ins} -> {t_outs}, the config "
                        f"says {ins} -> {outs}: rerun the model stage")
    g = sel.frf_true_real.values + 1j * sel.frf_true_imag.values
    fm, zm = sel.mode_frequency_true.values, sel.mode_damping_true.values
    keep = np.isfinite(fm)
    return g[:, :len(outs), :len(ins)], fm[keep], zm[keep]


def _fit_row(res: dict[str, Any], method: str, data: tuple[np.ndarray, ...], dt: float,
             f: np.ndarray, s: Mapping[str, Any]) -> None:
    # fit one pairing x version, score it against the truth; fills `res` in place
    u, y, uv, yv = data
    m = fit_model(method, u, y, dt, s)
    g_id = m.frf(f)
    err = frf_error_db(g_id, res["g_true"])
    fit = validation_fit(m, uv, yv, int(round(s["fit_segment"] / dt)))
    fm_id, zm_id = identified_modes(m.A, dt, s["frf"]["f_max"], s["zeta_max"])
    tol = s["tolerance_db"]
    res.update(model=m, g_id=g_id, err=err, fit=fit,
               bandwidth=match_bandwidth(f, err, tol),
               element_bw=np.array([[match_bandwidth(f, err[:, o, i], tol)
                                     for i in range(err.shape[2])]
                                    for o in range(err.shape[1])]),
               modes_id=fm_id, zeta_id=zm_id,
               modes_matched=match_modes(res["modes_true"], fm_id))
    # a NaN or inf fit is a failure, never "ok"
    res["status"] = ("ok" if np.all(np.isfinite(fit)) else
                     f"failed: validation fit is not finite ({np.round(fit, 1).tolist()} %)")


def identify_record(cfg: Mapping[str, Any], record: xr.Dataset, validation: xr.Dataset,
                    truth: xr.Dataset, method: str, tsa_record: xr.Dataset | None = None,
                    tsa_validation: xr.Dataset | None = None) -> xr.Dataset:
    """Identify every configured pairing x data version of one record with one method.

    Parameters
    ----------
    cfg : mapping
        Validated configuration slice: ``campaign.settle`` and the ``identify`` section.
    record, validation : xarray.Dataset
        Records (``gbpipe.simulate.test``, or measured): the one identified and the one
        the fit % is computed on (never used for fitting).
    truth : xarray.Dataset
        The model stage's ``truth.nc``: true FRFs on the identification grid and modes.
    method : {"pbsid", "moesp", "n4sid"}
    tsa_record, tsa_validation : xarray.Dataset, optional
        ``tsa_tests`` outputs of both records (required for the ``tsa`` version).

    Returns
    -------
    xarray.Dataset
        :func:`gbpipe.identify.models_dataset`; ``status`` says "ok" or why a row failed.

    Raises
    ------
    ValueError
        Unknown method, or ``tsa`` version without the ``tsa_tests`` outputs.
    gbpipe.errors.StageError
        Every row failed (the message lists each failure).
    """
    s = cfg["identify"]
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; use {', '.join(METHODS)}")
    if "tsa" in s["versions"] and (tsa_record is None or tsa_validation is None):
        raise ValueError("version 'tsa' needs tsa_record and tsa_validation (tsa_tests outputs)")
    fs = float(record.attrs["sample_rate"])
    settle = float(cfg["campaign"]["settle"])
    fs_id = float(s["sample_rate"])
    dt = 1.0 / fs_id
    f = np.asarray(truth.frequency.values, dtype=float)

    def prepared(ds: xr.Dataset, names: list[str], version: str,
                 tsa_ds: xr.Dataset | None) -> np.ndarray:
        return condition(version_signals(ds, names, version, tsa_ds), fs, settle, fs_id,
                         s["lowpass"])

    results = []
    for p in s["pairings"]:
        g_true, fm_true, zm_true = pairing_truth(truth, p)
        for version in s["versions"]:
            tr, tv = (tsa_record, tsa_validation) if version == "tsa" else (None, None)
            res = {"pairing": p["name"], "version": version, "inputs": list(p["inputs"]),
                   "outputs": list(p["outputs"]), "g_true": g_true, "modes_true": fm_true,
                   "zeta_true": zm_true, "model": None}
            data = (prepared(record, p["inputs"], version, tr),
                    prepared(record, p["outputs"], version, tr),
                    prepared(validation, p["inputs"], version, tv),
                    prepared(validation, p["outputs"], version, tv))
            try:
                _fit_row(res, method, data, dt, f, s)
            except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
                res.update(status=f"failed: {type(exc).__name__}: {exc}", model=None)
            if res["status"] == "ok":
                log.info("%s %-14s %-5s order %2d: bandwidth %6.1f Hz, fit %s %%", method,
                         p["name"], version, res["model"].order, res["bandwidth"],
                         np.round(res["fit"], 1))
            else:
                log.warning("%s %s/%s %s", method, p["name"], version, res["status"])
            results.append(res)
    if not any(r["status"] == "ok" for r in results):
        failures = "\n".join(f"  {r['pairing']}/{r['version']}: {r['status']}" for r in results)
        raise StageError(f"identify {method} on {record.attrs.get('test', '?')} "
                         f"({record.attrs.get('profile', '?')}): all {len(results)} "
                         f"identifications failed:\n{failures}")
    return models_dataset(results, f, dt, method, s, record, validation)
