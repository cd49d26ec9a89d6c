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

from gbpipe.lti import pad

__all__ = ["MODE_TOLERANCE", "models_dataset", "model_matrices"]

#: Relative distance [-] within which an identified mode matches a true one (stored as the
#: ``mode_tolerance`` attribute, which the table reads).
MODE_TOLERANCE = 0.02


#: Mixed units of the identified matrices (``comment`` attribute).
_MAT_NOTE = ("mixed units: state in identified coordinates; inputs and outputs in the units "
             "of the pairing's signals (frf_unit), at the identification sample time")
_FRF = ("model", "frequency", "output", "input")
#: ``units`` of FRF arrays whose models have different units (``frf_unit`` per model).
_FRF_MIXED = "mixed (see frf_unit)"

#: The float variables of :func:`models_dataset`: (variable, key of its padded array,
#: dimensions, units, long name, comment or None), in file order.
_ARRAYS: tuple[tuple[str, str, tuple[str, ...], str, str, str | None], ...] = (
    ("A", "A", ("model", "state", "state_col"), "1",
     "identified discrete-time state matrix A", None),
    ("B", "B", ("model", "state", "input"), "1", "identified input matrix B", _MAT_NOTE),
    ("C", "C", ("model", "output", "state"), "1", "identified output matrix C", _MAT_NOTE),
    ("D", "D", ("model", "output", "input"), "1", "identified feedthrough matrix D", _MAT_NOTE),
    ("K", "K", ("model", "state", "output"), "1", "identified innovation (Kalman) gain K",
     _MAT_NOTE),
    ("noise_cov", "noise_cov", ("model", "output", "output_col"), "1",
     "innovation covariance", "output units squared, (rad/s)^2"),
    ("singular_values", "sv", ("model", "sv_index"), "1",
     "singular values of the order decision (scaled data)", None),
    ("frf_identified_real", "frf_re", _FRF, _FRF_MIXED, "identified FRF, real part", None),
    ("frf_identified_imag", "frf_im", _FRF, _FRF_MIXED, "identified FRF, imaginary part",
     None),
    ("frf_identified_lower_db", "frf_lo", _FRF, "dB",
     "lower bound of the identified FRF magnitude (20 log10 |G|; jackknife over record "
     "groups, see the bounds_confidence attribute)", None),
    ("frf_identified_upper_db", "frf_hi", _FRF, "dB",
     "upper bound of the identified FRF magnitude (20 log10 |G|; jackknife over record "
     "groups, see the bounds_confidence attribute)", None),
    ("frf_reference_real", "ref_re", _FRF, _FRF_MIXED,
     "reference FRF (see the reference attribute), real part", None),
    ("frf_reference_imag", "ref_im", _FRF, _FRF_MIXED,
     "reference FRF (see the reference attribute), imaginary part", None),
    ("frf_reference_lower", "ref_lo", _FRF, _FRF_MIXED,
     "lower 95 % bound of the reference FRF magnitude (NaN: exact reference)", None),
    ("frf_reference_upper", "ref_hi", _FRF, _FRF_MIXED,
     "upper 95 % bound of the reference FRF magnitude (NaN: exact reference)", None),
    ("coherence", "coh", _FRF, "1",
     "coherence of the reference estimate (NaN: exact reference)", None),
    ("reference_band_max", "band", ("model",), "Hz",
     "highest frequency the reference can assess (its highest coherent frequency)", None),
    ("assessable", "assess", ("model", "frequency"), "1",
     "1 where the reference can judge a model (coherent estimate, or the truth), else 0",
     None),
    ("frf_error", "err", _FRF, "dB",
     "FRF magnitude error, identified vs reference (0 inside the reference's 95 % bounds, "
     "NaN above its band)", None),
    ("match_bandwidth", "bw", ("model",), "Hz",
     "highest frequency up to which every FRF element is within tolerance of the reference",
     "NaN for a failed row (no usable model)"),
    ("stable", "stable", ("model",), "1",
     "1 if no pole grows faster than the reference's modes by more than x2 per validation "
     "segment, else 0", "NaN: unknown (failed row, no usable model)"),
    ("element_match_bandwidth", "ebw", ("model", "output", "input"), "Hz",
     "match bandwidth per FRF element", None),
    ("fit", "fit", ("model", "output"), "percent",
     "simulation fit on the validation record (x0 estimated)", None),
    ("mode_true", "mt", ("model", "mode"), "Hz",
     "true modal frequency in the band (none for a measured record)", None),
    ("mode_true_damping", "zt", ("model", "mode"), "1", "true modal damping ratio", None),
    ("mode_matched", "mm", ("model", "mode"), "Hz",
     "identified modal frequency nearest to the true mode", None),
    ("mode_identified", "mi", ("model", "mode_id"), "Hz",
     "identified lightly damped modal frequency in the band", None),
    ("mode_identified_damping", "zi", ("model", "mode_id"), "1",
     "identified modal damping ratio", None),
)


def person_unit(unit: str) -> str:
    """A unit as a person writes it in a label: products with a middle dot (``N m`` ->
    ``N·m``)."""
    return "·".join(str(unit).split())


def ratio_unit(out: str, inp: str) -> str:
    """Unit of an FRF from ``inp`` to ``out`` as a person writes it, e.g.
    ``(rad/s)/(N·m)`` (never ``rad s-1 N-1 m-1``, which reads as rad/(s·N·m)) or
    ``N·m/N·m``."""
    o, i = person_unit(out), person_unit(inp)
    if o == i:
        return f"{o}/{i}"
    return f"({o})/({i})" if "/" in o else f"{o}/({i})" if ("/" in i or "·" in i) else f"{o}/{i}"


def frf_units(record: xr.Dataset, result: Mapping[str, Any]) -> str:
    """Unit of one model's FRF from the record's signal units (:func:`ratio_unit`);
    ``mixed (see input_name, output_name)`` for a MIMO model whose elements differ."""
    def unit(name: str) -> str:
        return str(record[name].attrs.get("units", "1")) if name in record else "1"

    ratios = {ratio_unit(unit(o), unit(i)) for o in result["outputs"] for i in result["inputs"]}
    return ratios.pop() if len(ratios) == 1 else "mixed (see input_name, output_name)"


def _file_frf_units(per_model: Sequence[str]) -> str:
    # one CF unit for the whole array where every model shares it; a dimensionless ratio
    # (N·m/N·m) is "1" for CF (UDUNITS reads "N·m/N·m" as m²), else the ratio itself
    units = set(per_model)
    if len(units) != 1:
        return _FRF_MIXED
    u = units.pop()
    num, _, den = u.partition("/")
    return "1" if num == den else _FRF_MIXED if u.startswith("mixed") else u


def models_dataset(results: Sequence[Mapping[str, Any]], dt: float, method: str,
                   s: Mapping[str, Any], record: xr.Dataset,
                   validation: xr.Dataset | None) -> xr.Dataset:
    """The identify job's output: every model of one job on a ``model`` dimension.

    Parameters
    ----------
    results : sequence of mapping
        One per pairing x version, as :func:`gbpipe.identify.identify_record` collects
        them: ``pairing``, ``version``, ``inputs``, ``outputs``, ``status``, ``ref`` (a
        :class:`gbpipe.identify.reference.Reference`; all on one frequency grid), and for
        a fitted model ``model``, ``g_id``, ``err``, ``fit``, ``bandwidth``,
        ``element_bw``, ``modes_id``, ``zeta_id``, ``modes_matched`` (``model`` None when
        the fit raised).
    dt : float
        Identification sample interval [s].
    method : str
    s : mapping
        The validated ``identify`` section.
    record, validation : xarray.Dataset
        The identified and the validation record (their attributes are recorded);
        ``validation`` None when the end of ``record`` was held out.

    Returns
    -------
    xarray.Dataset
        Matrices NaN-padded to the largest order and channel count, with the chosen
        ``order`` (``identify.order`` may be ``"auto"``), ``n_inputs`` and ``n_outputs``
        of each model (docs/architecture.md, "Data contract").
    """
    nm = len(results)
    refs = [r["ref"] for r in results]
    f = refs[0].frequency
    models = [r["model"] for r in results]
    nx = max([m.order for m in models if m is not None] or [1])
    nu = max(len(r["inputs"]) for r in results)
    ny = max(len(r["outputs"]) for r in results)
    nsv = max([m.singular_values.size for m in models if m is not None] or [1])
    nmode = max([len(ref.modes) for ref in refs] + [1])
    nmid = max([len(r.get("modes_id", [])) for r in results] + [1])
    nf = f.size
    arr = {k: np.full(shape, np.nan) for k, shape in {
        "A": (nm, nx, nx), "B": (nm, nx, nu), "C": (nm, ny, nx), "D": (nm, ny, nu),
        "K": (nm, nx, ny), "noise_cov": (nm, ny, ny), "sv": (nm, nsv),
        **dict.fromkeys(("frf_re", "frf_im", "frf_lo", "frf_hi", "ref_re", "ref_im", "ref_lo",
                         "ref_hi", "coh", "err"), (nm, nf, ny, nu)),
        "bw": (nm,), "band": (nm,), "assess": (nm, nf), "stable": (nm,),
        "ebw": (nm, ny, nu), "fit": (nm, ny), "mt": (nm, nmode), "zt": (nm, nmode),
        "mm": (nm, nmode), "mi": (nm, nmid), "zi": (nm, nmid)}.items()}
    order = np.zeros(nm, dtype=np.int32)
    for k, r in enumerate(results):
        ref = r["ref"]
        for key, val in (("ref_re", ref.frf.real), ("ref_im", ref.frf.imag),
                         ("ref_lo", ref.lower), ("ref_hi", ref.upper), ("coh", ref.coherence),
                         ("mt", ref.modes), ("zt", ref.damping),
                         ("assess", ref.assessable.astype(float))):
            arr[key][k] = pad(val, arr[key].shape[1:])
        arr["band"][k] = ref.band_max
        arr["stable"][k] = r["verdict"].stable
        m = r["model"]
        if m is None:
            continue
        order[k] = m.order
        for key, val in (("A", m.A), ("B", m.B), ("C", m.C), ("D", m.D), ("K", m.K),
                         ("noise_cov", m.noise_cov), ("sv", m.singular_values),
                         ("frf_re", r["g_id"].real), ("frf_im", r["g_id"].imag),
                         ("frf_lo", r["g_lower_db"]), ("frf_hi", r["g_upper_db"]),
                         ("err", r["err"]), ("fit", r["fit"]),
                         ("mm", r["modes_matched"]), ("mi", r["modes_id"]),
                         ("zi", r["zeta_id"])):
            arr[key][k] = pad(np.asarray(val, dtype=float), arr[key].shape[1:])
        if r["status"] != "failed":  # a failed row claims no band
            arr["bw"][k] = r["bandwidth"]
            arr["ebw"][k] = pad(np.asarray(r["element_bw"], float), arr["ebw"].shape[1:])
    names = [f"{r['pairing']}/{r['version']}" for r in results]

    def strs(rows: list[list[str]], n: int) -> np.ndarray:
        return np.array([row + [""] * (n - len(row)) for row in rows], dtype=object)

    dims_m = ("model",)
    frf_unit = [frf_units(record, r) for r in results]
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
        "frf_unit": (dims_m, np.array(frf_unit, dtype=object),
                     {"units": "1", "long_name": "unit of this model's FRF (output per input)"}),
        "status": (dims_m, np.array([r["status"] for r in results], dtype=object),
                   {"units": "1", "long_name": "identification status: ok, poor or failed "
                                               "(gbpipe.identify.status)"}),
        "reason": (dims_m, np.array([r["reason"] for r in results], dtype=object),
                   {"units": "1", "long_name": "why the status: every unmet condition of ok, "
                                               "or why the row failed"}),
        "order": (dims_m, order, {"units": "1", "long_name": "identified model order"}),
        "order_source": (dims_m, np.array([r.get("order_source", f"identify.order = "
                                                 f"{s['order']}") for r in results],
                                          dtype=object),
                         {"units": "1", "long_name": "where the model order came from"}),
        "n_inputs": (dims_m, np.array([len(r["inputs"]) for r in results], dtype=np.int32),
                     {"units": "1", "long_name": "number of inputs"}),
        "n_outputs": (dims_m, np.array([len(r["outputs"]) for r in results], dtype=np.int32),
                      {"units": "1", "long_name": "number of outputs"}),
        **{name: (dims, arr[key], {"units": units, "long_name": long_name,
                                   **({"comment": comment} if comment else {})})
           for name, key, dims, units, long_name, comment in _ARRAYS},
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
    units = _file_frf_units(frf_unit)
    for name in ("frf_identified_real", "frf_identified_imag", "frf_reference_real",
                 "frf_reference_imag", "frf_reference_lower", "frf_reference_upper"):
        ds[name].attrs["units"] = units
    # what D is: estimated (identify.feedthrough), or held at 0 by the fit, in which case
    # only a reflection of out-of-band poles (which refits B and D) makes it non-zero
    ds["D"].attrs["long_name"] = ("identified feedthrough matrix D (estimated)"
                                  if s["feedthrough"] else
                                  "identified feedthrough matrix D (0 in the fit; refitted "
                                  "where out-of-band poles were reflected)")
    ds["sample_time"] = ((), dt, {"units": "s", "long_name": "identification sample time"})
    ds.attrs.update(method=method,
                    test=str(record.attrs.get("test", record.attrs.get("record", ""))),
                    profile=str(record.attrs.get("profile", "")),
                    validation_test=(str(validation.attrs.get("test", validation.attrs.get(
                        "record", ""))) if validation is not None else
                        f"held out: last {s['holdout']:g} of the record"),
                    reference=refs[0].kind, reference_description=refs[0].description,
                    tolerance_db=float(s["tolerance_db"]),
                    mode_tolerance=MODE_TOLERANCE, past=int(s["past"]),
                    future=int(s["future"]), order_setting=str(s["order"]),
                    max_order=int(s["max_order"]),
                    record_sample_rate=float(record.attrs["sample_rate"]),
                    bounds_confidence=float(s["bounds"]["confidence"]),
                    bounds_groups=int(s["bounds"]["groups"]),
                    bounds_methods=",".join(s["bounds"]["methods"]))
    return ds


def model_matrices(ds: xr.Dataset, model: str) -> tuple[np.ndarray, ...]:
    """The stored ``A, B, C, D`` of one model, unpadded (discrete time, ``ds.sample_time``)."""
    sel = ds.sel(model=model)
    n, m, l_ = int(sel.order), int(sel.n_inputs), int(sel.n_outputs)
    return (sel.A.values[:n, :n], sel.B.values[:n, :m], sel.C.values[:l_, :n],
            sel.D.values[:l_, :m])
