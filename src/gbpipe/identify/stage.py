"""The identification stage: every pairing x data version of one record with one method.

:func:`identify_record` fits the models of one job (test, profile, method), compares each
with its true model (:mod:`gbpipe.identify.truth`) and returns one dataset holding every
model of the job on a ``model`` dimension (matrices NaN-padded to the largest order and
channel count, with the actual ``order``, ``n_inputs`` and ``n_outputs``).
:func:`table_rows` turns such datasets into the rows of ``identification.csv`` -- reading
the stored metrics only, so the table is exactly what the NetCDF files hold.
:func:`model_matrices` gives one stored model back as matrices.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.identify import metrics
from gbpipe.identify.prepare import VERSIONS, condition, version_signals
from gbpipe.identify.truth import true_modes, truth_frf, truth_model

__all__ = ["METHODS", "settings", "identify_record", "fit_model", "validation_fit",
           "reflect_out_of_band",
           "model_matrices",
           "table_rows", "tsa_dataset"]

log = logging.getLogger("gbpipe")

METHODS = ("pbsid", "moesp", "n4sid")

#: Short names of the pairing signals (table and figure labels).
SHORT = {"motor_torque_driver": "Tdrv", "motor_torque_driven": "Tdrn",
         "speed_gb2_hss": "wdrv", "speed_gb1_hss": "wdrn", "speed_lss": "wlss",
         "torque_meter_driving": "Mdrv", "torque_meter_driven": "Mdrn"}

_DEFAULTS: dict[str, Any] = {
    "sample_rate": 1000.0, "lowpass": 0.8, "order": 24, "max_order": 40, "past": 100,
    "future": 50, "versions": list(VERSIONS), "methods": list(METHODS),
    "frf": {"f_min": 5.0, "f_max": 350.0, "points": 240}, "tolerance_db": 1.0,
    "zeta_max": 0.2, "mode_tolerance": 0.02, "tsa_keep_below": 0.5, "fit_segment": 2.0,
    "reflect_out_of_band": True,
}


def settings(cfg: Mapping[str, Any]) -> dict[str, Any]:
    """The ``identify`` section with defaults filled in, checked.

    Raises
    ------
    ValueError
        Missing section or pairings, unknown method or version, a bad grid.
    """
    if "identify" not in cfg:
        raise ValueError("config has no 'identify' section: add it (see docs/identify.md)")
    s = {**_DEFAULTS, **cfg["identify"]}
    s["frf"] = {**_DEFAULTS["frf"], **cfg["identify"].get("frf", {})}
    if not s.get("pairings"):
        raise ValueError("identify.pairings is empty: give at least one {name, inputs, outputs}")
    bad = [m for m in s["methods"] if m not in METHODS]
    if bad:
        raise ValueError(f"identify.methods {bad} unknown; use {', '.join(METHODS)}")
    bad = [v for v in s["versions"] if v not in VERSIONS]
    if bad:
        raise ValueError(f"identify.versions {bad} unknown; use {', '.join(VERSIONS)}")
    fr = s["frf"]
    if not 0 < fr["f_min"] < fr["f_max"] < s["sample_rate"] / 2:
        raise ValueError("identify.frf needs 0 < f_min < f_max < identify.sample_rate / 2")
    names = [p["name"] for p in s["pairings"]]
    if len(set(names)) != len(names):
        raise ValueError(f"identify.pairings names {names} must be unique")
    return s


def fit_model(method: str, u: np.ndarray, y: np.ndarray, dt: float, s: Mapping[str, Any]):
    """Run one subspace method with the configured order and windows.

    PBSID takes ``past`` (VARX order) and ``future``; MOESP and N4SID take ``future`` as
    their horizon and ``past`` as the instrument window. ``D = 0`` for all three: the
    motor torque reaches no speed without dynamics, and closed-loop data bias a D estimate.
    """
    from gbpipe import sysid

    order = s["order"]
    max_order = s.get("max_order")
    past, fut = int(s["past"]), int(s["future"])
    if method == "pbsid":
        m = sysid.pbsid(u, y, order, past, fut, dt=dt, max_order=max_order)
    elif method in ("moesp", "n4sid"):
        m = getattr(sysid, method)(u, y, order, fut, dt, past=past, max_order=max_order)
    else:
        raise ValueError(f"unknown method {method!r}; use {', '.join(METHODS)}")
    f_pass = float(s["lowpass"]) * 0.5 / dt
    return reflect_out_of_band(m, f_pass) if s.get("reflect_out_of_band", True) else m


def reflect_out_of_band(model, f_pass: float):
    """Reflect unstable poles above the anti-aliasing pass band into the unit circle.

    The decimation filter leaves the band from ``f_pass`` [Hz] to Nyquist empty; on clean
    (noise-free) data nothing constrains poles there and the subspace step may place an
    unstable one (typically real, at z ~ -1.07). It carries no information, but it makes
    every simulation diverge. Each such pole ``z`` becomes ``1 / conj(z)`` and its residue is
    scaled by ``1 / |z|``, which leaves the magnitude of its term unchanged at every
    frequency (an all-pass factor), so the FRF magnitude in the band is untouched. In-band
    unstable poles (the true 1.3 Hz mode with one loop opened is unstable) are kept.
    """
    from dataclasses import replace

    lam, V = np.linalg.eig(model.A)
    s_c = np.log(lam.astype(complex)) / model.dt
    bad = (np.abs(lam) > 1.0) & (np.abs(s_c) / (2 * np.pi) > f_pass)
    if not bad.any() or np.linalg.cond(V) > 1e10:
        return model
    new = lam.copy()
    new[bad] = 1.0 / np.conj(lam[bad])
    scale = np.ones(lam.size, dtype=complex)
    scale[bad] = 1.0 / np.abs(lam[bad])
    Vi = np.linalg.inv(V)
    a = (V @ np.diag(new) @ Vi).real
    b = (V @ np.diag(scale) @ Vi @ model.B).real
    return replace(model, A=a, B=b, info={**model.info, "reflected_poles": int(bad.sum())})


def validation_fit(model, u: np.ndarray, y: np.ndarray, segment: int) -> np.ndarray:
    """Simulation fit [%] per output on a validation record, in segments.

    The record is cut into segments of ``segment`` samples; each is simulated from its own
    least-squares initial state and the simulations are joined; the fit is
    ``100 (1 - ||y - y_sim|| / ||y - mean y||)`` over the whole record. Segments, because
    the true model from a torque to a speed is not stable on its own (rigid-body integrator;
    with only one loop closed the 1.3 Hz motor-against-motor mode is even unstable): a
    single 40 s simulation of even a very good model drifts away, which says nothing about
    its dynamics. A model that fails to simulate gives NaN.
    """
    n = len(u)
    segment = max(2 * model.order, min(segment, n))
    y_sim = np.empty_like(y)
    with np.errstate(all="ignore"):
        try:
            for a in range(0, n, segment):
                b = min(n, a + segment)
                if b - a < model.order:  # too short to estimate a state: join to the previous
                    y_sim[a:b] = y[a:b]
                    continue
                x0 = model.estimate_x0(u[a:b], y[a:b])
                y_sim[a:b] = model.simulate(u[a:b], x0)
        except (ValueError, np.linalg.LinAlgError):
            return np.full(y.shape[1], np.nan)
    fit = metrics.fit_percent(y, y_sim)
    return np.where(np.isfinite(fit), fit, np.nan)


def _pad(a: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    out = np.full(shape, np.nan)
    out[tuple(slice(0, n) for n in a.shape)] = a
    return out


def identify_record(cfg: Mapping[str, Any], record: xr.Dataset, validation: xr.Dataset,
                    method: str, tsa_record: xr.Dataset | None = None,
                    tsa_validation: xr.Dataset | None = None) -> xr.Dataset:
    """Identify every configured pairing x data version of one record with one method.

    Parameters
    ----------
    cfg : mapping
        Configuration with ``gearbox``, ``bench``, ``campaign.settle`` and ``identify``.
    record, validation : xarray.Dataset
        Simulated records (``gbpipe.simulate.test``): the one identified and the one the
        fit % is computed on (never used for fitting).
    method : {"pbsid", "moesp", "n4sid"}
    tsa_record, tsa_validation : xarray.Dataset, optional
        ``tsa_tests`` outputs of both records (required for the ``tsa`` version).

    Returns
    -------
    xarray.Dataset
        On ``model`` (``<pairing>/<version>``): matrices, singular values, FRFs on
        ``frequency`` [Hz] (identified and true), FRF error [dB], match bandwidth [Hz],
        validation fit [%], true and identified modal frequencies [Hz].

    Raises
    ------
    ValueError
        Bad settings or method, before any fitting.
    """
    s = settings(cfg)
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; use {', '.join(METHODS)}")
    if "tsa" in s["versions"] and (tsa_record is None or tsa_validation is None):
        raise ValueError("version 'tsa' needs tsa_record and tsa_validation (tsa_tests outputs)")
    fs = float(record.attrs["sample_rate"])
    settle = float(cfg["campaign"]["settle"])
    fs_id = float(s["sample_rate"])
    dt = 1.0 / fs_id
    fr = s["frf"]
    f = np.geomspace(fr["f_min"], fr["f_max"], int(fr["points"]))
    results = []
    for p in s["pairings"]:
        truth = truth_model(cfg, p["inputs"], p["outputs"])
        g_true = truth_frf(truth, f)
        fm_true, zm_true = true_modes(truth.A, fr["f_max"], s["zeta_max"])
        for version in s["versions"]:
            tr, tv = (tsa_record, tsa_validation) if version == "tsa" else (None, None)
            u = condition(version_signals(record, p["inputs"], version, tr), fs, settle, fs_id,
                          s["lowpass"])
            y = condition(version_signals(record, p["outputs"], version, tr), fs, settle, fs_id,
                          s["lowpass"])
            uv = condition(version_signals(validation, p["inputs"], version, tv), fs, settle,
                           fs_id, s["lowpass"])
            yv = condition(version_signals(validation, p["outputs"], version, tv), fs, settle,
                           fs_id, s["lowpass"])
            res = {"pairing": p["name"], "version": version, "inputs": list(p["inputs"]),
                   "outputs": list(p["outputs"]), "g_true": g_true, "modes_true": fm_true,
                   "zeta_true": zm_true}
            try:
                m = fit_model(method, u, y, dt, s)
            except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
                log.warning("%s %s/%s failed: %s", method, p["name"], version, exc)
                res.update(status=f"failed: {exc}", model=None)
                results.append(res)
                continue
            g_id = m.frf(f)
            err = metrics.frf_error_db(g_id, g_true)
            fit = validation_fit(m, uv, yv, int(round(s["fit_segment"] * fs_id)))
            fm_id, zm_id = metrics.identified_modes(m.A, dt, fr["f_max"], s["zeta_max"])
            res.update(status="ok", model=m, g_id=g_id, err=err, fit=fit,
                       bandwidth=metrics.match_bandwidth(f, err, s["tolerance_db"]),
                       element_bw=np.array([[metrics.match_bandwidth(f, err[:, o, i],
                                                                     s["tolerance_db"])
                                              for i in range(err.shape[2])]
                                             for o in range(err.shape[1])]),
                       modes_id=fm_id, zeta_id=zm_id,
                       modes_matched=metrics.match_modes(fm_true, fm_id))
            log.info("%s %-14s %-5s order %2d: bandwidth %6.1f Hz, fit %s %%", method,
                     p["name"], version, m.order, res["bandwidth"], np.round(fit, 1))
            results.append(res)
    return _dataset(results, f, dt, method, s, record, validation)


def _dataset(results: list[dict], f: np.ndarray, dt: float, method: str, s: Mapping[str, Any],
             record: xr.Dataset, validation: xr.Dataset) -> xr.Dataset:
    nm = len(results)
    models = [r["model"] for r in results]
    nx = max([m.order for m in models if m is not None] or [1])
    nu = max(len(r["inputs"]) for r in results)
    ny = max(len(r["outputs"]) for r in results)
    nsv = max([m.singular_values.size for m in models if m is not None] or [1])
    nmode = max([len(r["modes_true"]) for r in results] + [1])
    nmid = max([len(r.get("modes_id", [])) for r in results] + [1])
    nf = f.size
    arr = {k: np.full(shape, np.nan) for k, shape in {
        "A": (nm, nx, nx), "B": (nm, nx, nu), "C": (nm, ny, nx), "D": (nm, ny, nu),
        "K": (nm, nx, ny), "noise_cov": (nm, ny, ny), "sv": (nm, nsv),
        "frf_re": (nm, nf, ny, nu), "frf_im": (nm, nf, ny, nu), "true_re": (nm, nf, ny, nu),
        "true_im": (nm, nf, ny, nu), "err": (nm, nf, ny, nu), "bw": (nm,),
        "ebw": (nm, ny, nu), "fit": (nm, ny), "mt": (nm, nmode), "zt": (nm, nmode),
        "mm": (nm, nmode), "mi": (nm, nmid), "zi": (nm, nmid)}.items()}
    order = np.zeros(nm, dtype=np.int32)
    for k, r in enumerate(results):
        g = r["g_true"]
        arr["true_re"][k] = _pad(g.real, (nf, ny, nu))
        arr["true_im"][k] = _pad(g.imag, (nf, ny, nu))
        arr["mt"][k] = _pad(r["modes_true"], (nmode,))
        arr["zt"][k] = _pad(r["zeta_true"], (nmode,))
        m = r["model"]
        if m is None:
            continue
        order[k] = m.order
        for key, val in (("A", m.A), ("B", m.B), ("C", m.C), ("D", m.D), ("K", m.K),
                         ("noise_cov", m.noise_cov), ("sv", m.singular_values),
                         ("frf_re", r["g_id"].real), ("frf_im", r["g_id"].imag),
                         ("err", r["err"]), ("ebw", r["element_bw"]), ("fit", r["fit"]),
                         ("mm", r["modes_matched"]), ("mi", r["modes_id"]),
                         ("zi", r["zeta_id"])):
            arr[key][k] = _pad(np.asarray(val, dtype=float), arr[key].shape[1:])
        arr["bw"][k] = r["bandwidth"]
    names = [f"{r['pairing']}/{r['version']}" for r in results]

    def strs(rows: list[list[str]], n: int) -> np.ndarray:
        return np.array([row + [""] * (n - len(row)) for row in rows], dtype=object)

    mat_note = ("mixed units: state in identified coordinates; inputs in N m, outputs in "
                "rad/s, at the identification sample time")
    dims_m = ("model",)
    v = {
        "pairing": (dims_m, np.array([r["pairing"] for r in results], dtype=object),
                    {"units": "1", "long_name": "signal pairing name"}),
        "version": (dims_m, np.array([r["version"] for r in results], dtype=object),
                    {"units": "1", "long_name": "data version (clean, raw measured-like, "
                                                "after TSA harmonic removal)"}),
        "input_name": (("model", "input"), strs([r["inputs"] for r in results], nu),
                       {"units": "1", "long_name": "input signal of each input channel"}),
        "output_name": (("model", "output"), strs([r["outputs"] for r in results], ny),
                        {"units": "1", "long_name": "output signal of each output channel"}),
        "status": (dims_m, np.array([r["status"] for r in results], dtype=object),
                   {"units": "1", "long_name": "identification status"}),
        "order": (dims_m, order, {"units": "1", "long_name": "identified model order"}),
        "n_inputs": (dims_m, np.array([len(r["inputs"]) for r in results], dtype=np.int32),
                     {"units": "1", "long_name": "number of inputs"}),
        "n_outputs": (dims_m, np.array([len(r["outputs"]) for r in results], dtype=np.int32),
                      {"units": "1", "long_name": "number of outputs"}),
        "A": (("model", "state", "state_col"), arr["A"],
              {"units": "1", "long_name": "identified discrete-time state matrix A"}),
        "B": (("model", "state", "input"), arr["B"],
              {"units": "1", "long_name": "identified input matrix B", "comment": mat_note}),
        "C": (("model", "output", "state"), arr["C"],
              {"units": "1", "long_name": "identified output matrix C", "comment": mat_note}),
        "D": (("model", "output", "input"), arr["D"],
              {"units": "1", "long_name": "identified feedthrough matrix D (fixed 0)",
               "comment": mat_note}),
        "K": (("model", "state", "output"), arr["K"],
              {"units": "1", "long_name": "identified innovation (Kalman) gain K",
               "comment": mat_note}),
        "noise_cov": (("model", "output", "output_col"), arr["noise_cov"],
                      {"units": "1", "long_name": "innovation covariance",
                       "comment": "output units squared, (rad/s)^2"}),
        "singular_values": (("model", "sv_index"), arr["sv"],
                            {"units": "1", "long_name": "singular values of the order "
                                                        "decision (scaled data)"}),
        "frf_identified_real": (("model", "frequency", "output", "input"), arr["frf_re"],
                                {"units": "rad s-1 N-1 m-1",
                                 "long_name": "identified FRF, real part"}),
        "frf_identified_imag": (("model", "frequency", "output", "input"), arr["frf_im"],
                                {"units": "rad s-1 N-1 m-1",
                                 "long_name": "identified FRF, imaginary part"}),
        "frf_true_real": (("model", "frequency", "output", "input"), arr["true_re"],
                          {"units": "rad s-1 N-1 m-1",
                           "long_name": "true FRF (bench model, other loop closed), real part"}),
        "frf_true_imag": (("model", "frequency", "output", "input"), arr["true_im"],
                          {"units": "rad s-1 N-1 m-1",
                           "long_name": "true FRF (bench model, other loop closed), "
                                        "imaginary part"}),
        "frf_error": (("model", "frequency", "output", "input"), arr["err"],
                      {"units": "dB", "long_name": "FRF magnitude error, identified vs true"}),
        "match_bandwidth": (dims_m, arr["bw"],
                            {"units": "Hz", "long_name": "highest frequency up to which every "
                                                         "FRF element is within tolerance"}),
        "element_match_bandwidth": (("model", "output", "input"), arr["ebw"],
                                    {"units": "Hz", "long_name": "match bandwidth per FRF "
                                                                 "element"}),
        "fit": (("model", "output"), arr["fit"],
                {"units": "percent", "long_name": "simulation fit on the validation record "
                                                  "(x0 estimated)"}),
        "mode_true": (("model", "mode"), arr["mt"],
                      {"units": "Hz", "long_name": "true modal frequency in the band"}),
        "mode_true_damping": (("model", "mode"), arr["zt"],
                              {"units": "1", "long_name": "true modal damping ratio"}),
        "mode_matched": (("model", "mode"), arr["mm"],
                         {"units": "Hz", "long_name": "identified modal frequency nearest to "
                                                      "the true mode"}),
        "mode_identified": (("model", "mode_id"), arr["mi"],
                            {"units": "Hz", "long_name": "identified lightly damped modal "
                                                         "frequency in the band"}),
        "mode_identified_damping": (("model", "mode_id"), arr["zi"],
                                    {"units": "1", "long_name": "identified modal damping "
                                                                "ratio"}),
    }
    coords = {
        "model": ("model", np.array(names, dtype=object),
                  {"units": "1", "long_name": "model: pairing/data version"}),
        "frequency": ("frequency", f, {"units": "Hz", "long_name": "frequency"}),
        "state": ("state", np.arange(nx), {"units": "1", "long_name": "state index"}),
        "state_col": ("state_col", np.arange(nx), {"units": "1", "long_name": "state index "
                                                                             "(columns)"}),
        "input": ("input", np.arange(nu), {"units": "1", "long_name": "input channel"}),
        "output": ("output", np.arange(ny), {"units": "1", "long_name": "output channel"}),
        "output_col": ("output_col", np.arange(ny), {"units": "1",
                                                      "long_name": "output channel (columns)"}),
        "sv_index": ("sv_index", np.arange(nsv), {"units": "1",
                                                  "long_name": "singular value index"}),
        "mode": ("mode", np.arange(nmode), {"units": "1", "long_name": "true mode index"}),
        "mode_id": ("mode_id", np.arange(nmid), {"units": "1",
                                                 "long_name": "identified mode index"}),
    }
    ds = xr.Dataset(v, coords=coords)
    ds["sample_time"] = ((), dt, {"units": "s", "long_name": "identification sample time"})
    ds.attrs.update(method=method, test=str(record.attrs.get("test", "")),
                    profile=str(record.attrs.get("profile", "")),
                    validation_test=str(validation.attrs.get("test", "")),
                    tolerance_db=float(s["tolerance_db"]), past=int(s["past"]),
                    future=int(s["future"]), order_setting=str(s["order"]),
                    record_sample_rate=float(record.attrs["sample_rate"]))
    return ds


def model_matrices(ds: xr.Dataset, model: str) -> tuple[np.ndarray, ...]:
    """The stored ``A, B, C, D`` of one model, unpadded (discrete time, ``ds.sample_time``)."""
    sel = ds.sel(model=model)
    n, m, l_ = int(sel.order), int(sel.n_inputs), int(sel.n_outputs)
    return (sel.A.values[:n, :n], sel.B.values[:n, :m], sel.C.values[:l_, :n],
            sel.D.values[:l_, :m])


def _short(names: Sequence[str]) -> str:
    return "+".join(SHORT.get(n, n) for n in names)


def table_rows(datasets: Sequence[xr.Dataset]) -> list[dict[str, Any]]:
    """Rows of ``identification.csv``: one per test x profile x method x pairing x version.

    Every number is read from the datasets (what the NetCDF files store). Rows of the
    ``tsa`` version also say how much of the clean-data bandwidth harmonic removal
    recovers: ``100 (bw_tsa - bw_raw) / (bw_clean - bw_raw)`` when clean beats raw.
    """
    rows = []
    for ds in datasets:
        for k in range(ds.sizes["model"]):
            sel = ds.isel(model=k)
            nu, ny = int(sel.n_inputs), int(sel.n_outputs)
            ins = [str(x) for x in sel.input_name.values[:nu]]
            outs = [str(x) for x in sel.output_name.values[:ny]]
            fit = sel.fit.values[:ny]
            ebw = sel.element_match_bandwidth.values[:ny, :nu]
            mt = sel.mode_true.values
            mm = sel.mode_matched.values
            ok = np.isfinite(mt)
            rel = np.abs(mm[ok] - mt[ok]) / mt[ok]
            rows.append({
                "test": ds.attrs["test"], "profile": ds.attrs["profile"],
                "method": ds.attrs["method"], "pairing": str(sel.pairing.values),
                "version": str(sel.version.values), "inputs": _short(ins),
                "outputs": _short(outs), "validation": ds.attrs["validation_test"],
                "order": int(sel.order), "match_bandwidth_hz": float(sel.match_bandwidth),
                "element_bandwidth_hz": ";".join(
                    f"{SHORT.get(outs[o], outs[o])}<-{SHORT.get(ins[i], ins[i])}:"
                    f"{ebw[o, i]:.4g}" for o in range(ny) for i in range(nu)),
                "within_tol_pct": float(100.0 * np.mean(np.all(np.abs(
                    sel.frf_error.values[:, :ny, :nu]) <= ds.attrs["tolerance_db"],
                    axis=(1, 2)))),
                "fit_pct": float(np.mean(fit)) if np.all(np.isfinite(fit)) else float("nan"),
                "fit_min_pct": float(np.min(fit)) if np.all(np.isfinite(fit)) else float("nan"),
                "stable": bool(np.all(np.abs(np.linalg.eigvals(
                    np.nan_to_num(sel.A.values[:int(sel.order), :int(sel.order)]))) < 1.0))
                if int(sel.order) else False,
                "modes_true": int(ok.sum()),
                "modes_within_tol": int(np.sum(rel <= 0.02)),
                "status": str(sel.status.values),
            })
    by_key = {(r["test"], r["profile"], r["method"], r["pairing"], r["version"]): r
              for r in rows}
    for r in rows:
        if r["version"] != "tsa":
            continue
        key = (r["test"], r["profile"], r["method"], r["pairing"])
        clean, raw = by_key.get(key + ("clean",)), by_key.get(key + ("raw",))
        if clean is None or raw is None:
            continue
        gain = clean["match_bandwidth_hz"] - raw["match_bandwidth_hz"]
        r["recovered_bandwidth_pct"] = (
            100.0 * (r["match_bandwidth_hz"] - raw["match_bandwidth_hz"]) / gain
            if gain > 0 else float("nan"))
    return rows


def tsa_dataset(record: xr.Dataset, names: Sequence[str], stages: Sequence[Mapping[str, Any]],
                tsa_cfg: Mapping[str, Any], keep_below: float) -> xr.Dataset:
    """The ``tsa_tests`` output: measured-like signals of a record after harmonic removal."""
    from gbpipe.identify.prepare import tsa_residuals

    res = tsa_residuals(record, names, stages, tsa_cfg, keep_below)
    ds = xr.Dataset(coords={"time": ("time", record.time.values,
                                     {"units": "s", "long_name": "time from record start"})})
    for n, x in res.items():
        unit = record[f"{n}_measured"].attrs.get("units", "1")
        ds[n] = ("time", x, {"units": unit, "long_name": f"{n}, measured-like after TSA removal "
                                                         f"of {', '.join(tsa_cfg['tests'])}"})
    ds.attrs.update(test=str(record.attrs.get("test", "")),
                    profile=str(record.attrs.get("profile", "")),
                    sample_rate=float(record.attrs["sample_rate"]),
                    removed_cycles=",".join(tsa_cfg["tests"]), n_cycles=int(tsa_cfg["n_cycles"]))
    return ds
