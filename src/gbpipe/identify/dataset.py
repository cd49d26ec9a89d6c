"""The identify job's NetCDF: every model of one job, padded to common dimensions.

:func:`models_dataset` stores the models of one job (test, profile, method) on a ``model``
dimension (``<pairing>/<version>``): matrices NaN-padded to the largest order and channel
count, with the actual ``order``, ``n_inputs`` and ``n_outputs``; identified and true FRFs,
errors, match bandwidths, validation fits and modes. :func:`model_matrices` gives one
stored model back as matrices.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

__all__ = ["MODE_TOLERANCE", "models_dataset", "model_matrices", "pad"]

#: Relative distance [-] within which an identified mode matches a true one (stored as the
#: ``mode_tolerance`` attribute, which the table reads).
MODE_TOLERANCE = 0.02


def pad(a: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """``a`` in the leading corner of a NaN array of ``shape`` (models of unequal size)."""
    out = np.full(shape, np.nan)
    out[tuple(slice(0, n) for n in a.shape)] = a
    return out


def models_dataset(results: Sequence[Mapping[str, Any]], f: np.ndarray, dt: float, method: str,
                   s: Mapping[str, Any], record: xr.Dataset,
                   validation: xr.Dataset) -> xr.Dataset:
    """The identify job's output: every model of one job on a ``model`` dimension.

    Parameters
    ----------
    results : sequence of mapping
        One per pairing x version, as :func:`gbpipe.identify.identify_record` collects
        them: ``pairing``, ``version``, ``inputs``, ``outputs``, ``status``, ``g_true``,
        ``modes_true``, ``zeta_true``, and for a fitted model ``model``, ``g_id``, ``err``,
        ``fit``, ``bandwidth``, ``element_bw``, ``modes_id``, ``zeta_id``,
        ``modes_matched`` (``model`` None when the fit raised).
    f : ndarray
        FRF grid [Hz].
    dt : float
        Identification sample interval [s].
    method : str
    s : mapping
        The validated ``identify`` section.
    record, validation : xarray.Dataset
        The identified and the validation record (their attributes are recorded).

    Returns
    -------
    xarray.Dataset
        Matrices NaN-padded to the largest order and channel count, with the chosen
        ``order`` (``identify.order`` may be ``"auto"``), ``n_inputs`` and ``n_outputs``
        of each model (docs/architecture.md, "Data contract").
    """
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
        arr["true_re"][k] = pad(g.real, (nf, ny, nu))
        arr["true_im"][k] = pad(g.imag, (nf, ny, nu))
        arr["mt"][k] = pad(r["modes_true"], (nmode,))
        arr["zt"][k] = pad(r["zeta_true"], (nmode,))
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
            arr[key][k] = pad(np.asarray(val, dtype=float), arr[key].shape[1:])
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
                    tolerance_db=float(s["tolerance_db"]),
                    mode_tolerance=MODE_TOLERANCE, past=int(s["past"]),
                    future=int(s["future"]), order_setting=str(s["order"]),
                    max_order=int(s["max_order"]),
                    record_sample_rate=float(record.attrs["sample_rate"]))
    return ds


def model_matrices(ds: xr.Dataset, model: str) -> tuple[np.ndarray, ...]:
    """The stored ``A, B, C, D`` of one model, unpadded (discrete time, ``ds.sample_time``)."""
    sel = ds.sel(model=model)
    n, m, l_ = int(sel.order), int(sel.n_inputs), int(sel.n_outputs)
    return (sel.A.values[:n, :n], sel.B.values[:n, :m], sel.C.values[:l_, :n],
            sel.D.values[:l_, :m])
