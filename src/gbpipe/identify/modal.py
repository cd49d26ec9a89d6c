"""The modes of a bench record, chosen by the data: stabilization diagrams per pairing.

For a measured record gbpipe assumes nothing of the configured gearbox. For each pairing of
``identify.pairings``, the record is conditioned as the identify stage does it (operating
point, causal decimation to ``identify.sample_rate``: :class:`ConditionedRecord`, raw
version) and two stabilization diagrams are read off it:

* a subspace one (``identify.stabilization.method``, default PBSID: consistent in closed
  loop) over the model orders ``identify.stabilization.orders``
  (:func:`gbpipe.sysid.stabilization_diagram`);
* an LSCF one on the nonparametric FRF of the same data (the identify stage's reference,
  :func:`gbpipe.identify.nonparametric_reference`, on every line but DC up to Nyquist so
  that no band edge lies in the reported band), over ``lscf_orders``
  (:func:`gbpipe.sysid.lscf_stabilization`).

Each cluster of stable poles is labelled ``harmonic`` when it lies on a shaft-order line
of the record's speed range (:mod:`gbpipe.identify.harmonic_lines`), else ``mode``. The
subspace diagram's order (the lowest that holds every cluster, harmonics included: the
identify stage's model must explain the lines too) is ``model_order``, which the identify
stage of the record uses. docs/modal.md.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.errors import DataError
from gbpipe.identify.bench_data import operating_point_settle
from gbpipe.identify.harmonic_lines import (
    HarmonicBands,
    record_harmonic_bands,
    reference_angle,
    speed_frequency_range,
)
from gbpipe.identify.mode_kinds import Cluster, Evidence, PairingData, record_evidence
from gbpipe.identify.orders import order_windows
from gbpipe.identify.prepare import ConditionedRecord
from gbpipe.identify.reference import Reference, nonparametric_reference
from gbpipe.io import longest_segment
from gbpipe.lti import pad
from gbpipe.sysid import (
    Stabilization,
    held_modes,
    lowest_order,
    lscf_stabilization,
    stabilization_diagram,
)

__all__ = ["record_modes", "modes_table_rows", "TABLE_COLUMNS", "order_range"]

log = logging.getLogger("gbpipe")

#: Columns of ``tables/modes_measured.csv``, in order.
TABLE_COLUMNS = ("record", "pairing", "method", "frequency_hz", "damping",
                 "frequency_spread_hz", "damping_spread", "n_orders", "kind", "evidence")


def order_range(bounds: Sequence[int], step: int) -> np.ndarray:
    """Model orders ``bounds[0], bounds[0] + step, ... <= bounds[1]`` (int array)."""
    return np.arange(int(bounds[0]), int(bounds[1]) + 1, int(step))


def _diagrams(u: np.ndarray, y: np.ndarray, ref: Reference, dt: float,
              s: Mapping[str, Any]) -> dict[str, Stabilization | str]:
    # both diagrams of one pairing; a failure is kept as its reason (status), not raised
    st = s["stabilization"]
    crit = {k: st[k] for k in ("frequency_tolerance", "damping_tolerance", "mac_min")}
    orders = order_range(st["orders"], st["step"])
    # the windows of the identify stage, lengthened where the highest order needs more
    # block rows than they give: a diagram is read off one projection, so its windows
    # must hold its largest order (the identify stage lengthens them alike)
    w = order_windows(s, int(orders[-1]), y.shape[1])
    # (the estimator's own defaults otherwise: on the bench example, PBSID with the
    # identify stage's estimated feedthrough held no cluster at its 62 Hz mode)
    windows = (w if st["method"] == "pbsid" else
               {"past": w["past"], "horizon": w["future"]})
    out: dict[str, Stabilization | str] = {}
    jobs = {st["method"]: lambda: stabilization_diagram(
                u, y, dt, orders, st["method"], max_damping=s["zeta_max"], **windows,
                **crit),
            "lscf": lambda: lscf_stabilization(
                ref.frequency, ref.frf, order_range(st["lscf_orders"], 1), dt,
                weights=_lscf_weights(ref),
                max_damping=s["zeta_max"], **crit)}
    for method, job in jobs.items():
        try:
            out[method] = job()
        except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
            out[method] = f"failed: {type(exc).__name__}: {exc}"
    return out


def _whole_band(u: np.ndarray, y: np.ndarray, fs: float, s: Mapping[str, Any],
                r: np.ndarray | None) -> Reference:
    """The nonparametric FRF the LSCF diagram fits: every Welch line but DC, to Nyquist.

    A frequency-domain fit leaves its polynomials free outside the fitted lines, and
    poles gather at the edges of a fitted band (PolyMAX practice: fit a band wider than
    the one reported). On the z-domain basis the lines from the first above DC to Nyquist
    constrain the whole unit circle (its lower half is the conjugate), so no edge is left
    inside the reported band ``frf.f_min``-``f_max`` and no margin has to be chosen; the
    lines above the anti-aliasing pass band are incoherent and weigh little
    (:func:`_lscf_weights`). H1 and the reference estimate divide the decimation filter
    out (it acts on input and output alike). DC is left out: the operating point is
    removed, so the estimate there is noise over noise.
    """
    resolution = 1.0 / float(s["nonparametric"]["segment"])
    whole = {**s, "frf": {**s["frf"], "f_min": 0.5 * resolution, "f_max": 0.5 * fs}}
    return nonparametric_reference(u, y, fs, whole, r)


def _lscf_weights(ref: Reference) -> np.ndarray:
    # each line of each output weighted by the inverse standard deviation of the estimate
    # (from its 95 % magnitude bounds, averaged over the inputs): the noisy, incoherent
    # lines count little, and outputs in different units count alike
    sd = np.nanmean(ref.upper - ref.lower, axis=2) / (2 * 1.96)
    return np.where(np.isfinite(sd) & (sd > 0), 1.0 / np.where(sd > 0, sd, 1.0), 0.0)


def record_modes(cfg: Mapping[str, Any], record: xr.Dataset,
                 orders: Sequence[float] = (), *,
                 speeds: Mapping[str, float] | None = None) -> xr.Dataset:
    """Stabilization diagrams, modes and model order of every pairing of one record.

    Parameters
    ----------
    cfg : mapping
        Validated configuration slice: ``campaign.settle``, the ``identify`` section
        (``pairings``, ``sample_rate``, ``lowpass``, ``past``, ``future``, ``zeta_max``,
        ``nonparametric``, ``frf``, ``stabilization``) and the root ``seed`` (0 when the
        slice has none).
    record : xarray.Dataset
        A bench record (:func:`gbpipe.measured.read`); a split record: its longest piece.
    orders : sequence of float
        Excitation orders of the reference shaft beyond its harmonics
        (``measured.<record>.orders``) [-].
    speeds : mapping str -> float, optional
        Speed signals of the record [rad/s] and the order of their shaft relative to the
        reference shaft (``measured.<record>.signals.<name>.shaft_order``); used when the
        record has no tacho. Without either, the record's own order-1 line is the
        reference (docs/modal.md).

    Returns
    -------
    xarray.Dataset
        Dims ``method`` (the subspace method, ``lscf``), ``pairing``, ``cluster``,
        ``order_index``, ``pole``, ``frequency``, ``band``; see docs/modal.md and the
        data contract. ``model_order`` (method, pairing) [1] is 0 where no mode was found
        or the diagram failed (``status`` says which).

    Raises
    ------
    gbpipe.errors.DataError
        A pairing's signal missing, a ``speeds`` signal that is not a speed.
    gbpipe.errors.PulseError
        An unusable pulse train.
    """
    s = cfg["identify"]
    record = longest_segment(record)
    fs_id = float(s["sample_rate"])
    resolution = 1.0 / float(s["nonparametric"]["segment"])
    st = s["stabilization"]
    # before long work: the bands of a measured speed (a tacho, or a speed signal); without
    # one the orders wait for the record's own order-1 line (mode_kinds)
    speed = "pulse_time" in record or bool(speeds)
    bands = record_harmonic_bands(record, orders if speed else (), resolution,
                                  st["shaft_harmonics"], s["frf"]["f_max"], speeds=speeds)
    # the operating point as the identify stage takes it (before the first excitation)
    inputs = list(dict.fromkeys(n for p in s["pairings"] for n in p["inputs"]))
    settle, _ = operating_point_settle(record, None, inputs, "raw",
                                       float(cfg["campaign"]["settle"]), s)
    rec = ConditionedRecord(record, {}, float(record.attrs["sample_rate"]), settle, fs_id,
                            s["lowpass"])
    for p in s["pairings"]:  # every signal is there before the first (long) diagram
        rec(list(p["inputs"]) + list(p["outputs"]) + list(p.get("reference", [])), "raw")
    results, refs, data = [], [], []
    angle = reference_angle(record, rec.times(), speeds) if speed else None  # of the lines
    for p in s["pairings"]:
        u, y = rec(p["inputs"], "raw"), rec(p["outputs"], "raw")
        r = rec(p["reference"], "raw") if "reference" in p else None
        refs.append(nonparametric_reference(u, y, fs_id, s, r))
        data.append(PairingData(y, list(p["outputs"]), fs_id, refs[-1].frequency,
                                refs[-1].coherence.reshape(refs[-1].frequency.size, -1)
                                .max(axis=1), angle))
        results.append(_diagrams(u, y, _whole_band(u, y, fs_id, s, r), 1.0 / fs_id, s))
        for method, res in results[-1].items():
            if isinstance(res, str):
                log.warning("%s %s: %s", p["name"], method, res)
            else:
                log.info("%s %s: %d clusters, order %d", p["name"], method,
                         len(res.clusters), res.order)
    kept = _in_band(s, results)
    clusters = [Cluster(j, m.frequency_hz, m.damping) for (_, j), ms in kept.items()
                for _, m in ms]
    evidence, bands = record_evidence(
        clusters, data, bands, orders, resolution,
        float(s["nonparametric"]["coherence_min"]), st["shaft_harmonics"],
        s["frf"]["f_max"], int(cfg.get("seed", 0)),
        {} if speed else _turning_shafts(record, 1.0 / resolution))
    return _dataset(s, [p["name"] for p in s["pairings"]], results, refs, bands, record,
                    kept, evidence)


def _turning_shafts(record: xr.Dataset, segment: float) -> dict[str, tuple[float, float]]:
    # the record's speed signals [rad/s] of a turning shaft (no shaft_order: their order
    # is not known) and their frequency range [Hz]: candidates for the order-1 line
    out = {}
    for name, v in record.data_vars.items():
        if v.attrs.get("units") == "rad/s" and v.dims == ("time",):
            try:
                out[str(name)] = speed_frequency_range(v.values, float(
                    record.attrs["sample_rate"]), 1.0, segment)
            except DataError:  # standing or reversing: no shaft speed, no candidate
                continue
    return out


def _in_band(s: Mapping[str, Any], results: list[dict[str, Any]]
             ) -> dict[tuple[str, int], list[tuple[int, Any]]]:
    # per (method, pairing index): the clusters in the FRF band, with their index in the
    # diagram: below the band lie the rigid-body and control modes the record is too
    # short to resolve, above it the anti-aliasing filter's edge
    f_lo, f_hi = float(s["frf"]["f_min"]), float(s["frf"]["f_max"])
    return {(method, j): [(c, m) for c, m in enumerate(r.clusters)
                          if f_lo <= m.frequency_hz <= f_hi]
            for j, res in enumerate(results) for method, r in res.items()
            if not isinstance(r, str)}


def _ragged(rows: Sequence[np.ndarray], width: int, fill: float = np.nan) -> np.ndarray:
    # one row per order (each at most width poles long), padded with fill
    return np.array([pad(r, (width,), fill) for r in rows]).reshape(len(rows), width)


def _indicator_db(ref: Reference) -> np.ndarray:
    # the mean over FRF elements of |H|^2, each normalised by its mean over frequency:
    # one dimensionless curve whose peaks are the modes whatever the units of the pairing
    h2 = np.abs(ref.frf.reshape(ref.frf.shape[0], -1)) ** 2
    return 10 * np.log10(np.mean(h2 / np.mean(h2, axis=0), axis=1))


def _dataset(s: Mapping[str, Any], names: list[str], results: list[dict[str, Any]],
             refs: list[Reference], bands: HarmonicBands, record: xr.Dataset,
             kept: Mapping[tuple[str, int], list[tuple[int, Any]]],
             evidence: Sequence[Evidence]) -> xr.Dataset:
    methods = list(results[0])
    nm, npair = len(methods), len(names)
    f_lo, f_hi = float(s["frf"]["f_min"]), float(s["frf"]["f_max"])
    n_cl = max([len(k) for k in kept.values()] + [1])
    n_ord = max(len(order_range(s["stabilization"][k], st))
                for k, st in (("orders", s["stabilization"]["step"]), ("lscf_orders", 1)))
    n_pole = max([len(p[0]) for res in results for r in res.values() if not isinstance(r, str)
                  for p in r.poles] + [1])
    shape_c, shape_p = (nm, npair, n_cl), (nm, npair, n_ord, n_pole)
    cl = {k: np.full(shape_c, np.nan) for k in ("f", "z", "fs", "zs", "n", "k", "kl", "c", "o")}
    kind = np.full(shape_c, "", dtype=object)
    why = np.full(shape_c, "", dtype=object)
    pf, pz = np.full(shape_p, np.nan), np.full(shape_p, np.nan)
    pstable = np.zeros(shape_p, np.int8)
    pcluster = np.full(shape_p, -1, np.int32)
    order_of = np.full((nm, n_ord), np.nan)
    model_order = np.zeros((nm, npair), np.int32)
    status = np.full((nm, npair), "ok", dtype=object)
    ev = iter(evidence)  # in the order of kept (record_modes)
    for (method, j), keep in kept.items():
        i, r = methods.index(method), results[j][method]
        for c, (_, m) in enumerate(keep):
            e = next(ev)
            cl["f"][i, j, c], cl["z"][i, j, c] = m.frequency_hz, m.damping
            cl["fs"][i, j, c], cl["zs"][i, j, c] = m.frequency_spread_hz, m.damping_spread
            cl["n"][i, j, c] = m.n_orders
            cl["k"][i, j, c], cl["kl"][i, j, c] = e.kurtosis, e.kurtosis_limit
            cl["c"][i, j, c], cl["o"][i, j, c] = e.coherence, e.line_order
            kind[i, j, c], why[i, j, c] = e.kind, e.text
        renumber = np.full(len(r.clusters) + 1, -1)  # stab's cluster -> kept; -1 stays
        renumber[[k for k, _ in keep]] = np.arange(len(keep))
        pf[i, j, :len(r.poles)] = _ragged([p[0] for p in r.poles], n_pole)
        pz[i, j, :len(r.poles)] = _ragged([p[1] for p in r.poles], n_pole)
        pstable[i, j, :len(r.poles)] = _ragged(r.stable, n_pole, 0)
        pcluster[i, j, :len(r.poles)] = _ragged([renumber[lab] for lab in r.labels],
                                                n_pole, -1)
    for j, res in enumerate(results):
        # the order the identify stage fits: the lowest that holds every mode either
        # method found in the band and the order lines of its own diagram (the model must
        # explain the lines it is fitted on); noise poles never count, and lines alone
        # (no mode) set no order
        modes = cl["f"][:, j][kind[:, j] == "mode"]
        tol = s["stabilization"]["frequency_tolerance"]
        for i, method in enumerate(methods):
            r = res[method]
            if isinstance(r, str):
                status[i, j] = r
                continue
            order_of[i, :len(r.orders)] = r.orders
            wanted = np.concatenate([modes, cl["f"][i, j][kind[i, j] == "harmonic"]])
            held = held_modes(r.poles, wanted, tol)
            model_order[i, j] = modes.size and lowest_order(r.orders, r.poles, wanted[held], tol)
            missing = modes[~held[:modes.size]]
            if not modes.size:
                status[i, j] = (f"no mode: no cluster of stable poles in {f_lo:g}-{f_hi:g} Hz "
                                "that is a mode (table evidence)")
            elif missing.size:
                status[i, j] = (f"poor: no order up to {int(r.orders[-1])} holds the mode(s) "
                                f"at {np.round(missing, 1).tolist()} Hz of the other method")
    dims_c, dims_p = ("method", "pairing", "cluster"), ("method", "pairing", "order_index",
                                                        "pole")
    f = refs[0].frequency
    one = "1"
    data = {
        "model_order": (("method", "pairing"), model_order,
                        {"units": one, "long_name": "model order the identify stage uses "
                         "(lowest order holding every mode of either method and its own "
                         "lines; 0: no mode)"}),
        "status": (("method", "pairing"), status,
                   {"units": one, "long_name": "ok, or why the diagram failed or found "
                    "no mode"}),
        "mode_frequency": (dims_c, cl["f"], {"units": "Hz", "long_name":
                                             "mean natural frequency of the cluster"}),
        "mode_damping": (dims_c, cl["z"], {"units": one, "long_name":
                                           "mean damping ratio of the cluster"}),
        "mode_frequency_spread": (dims_c, cl["fs"], {"units": "Hz", "long_name":
                                                     "standard deviation of the frequency "
                                                     "over the cluster"}),
        "mode_damping_spread": (dims_c, cl["zs"], {"units": one, "long_name":
                                                   "standard deviation of the damping "
                                                   "ratio over the cluster"}),
        "mode_n_orders": (dims_c, cl["n"], {"units": one, "long_name":
                                            "model orders the cluster is stable in"}),
        "mode_kind": (dims_c, kind, {"units": one, "long_name":
                                     "mode, harmonic (an order line) or spurious (noise)"}),
        "mode_evidence": (dims_c, why, {"units": one, "long_name": "why the kind, in words"}),
        "mode_kurtosis": (dims_c, cl["k"], {"units": one, "long_name": "lowest kurtosis of "
                                            "the outputs in the cluster's band"}),
        "mode_kurtosis_limit": (dims_c, cl["kl"], {"units": one, "long_name": "lowest "
                                                   "kurtosis a mode of the cluster gives"}),
        "mode_coherence": (dims_c, cl["c"], {"units": one, "long_name": "highest coherence "
                                             "in the cluster's band"}),
        "mode_line_order": (dims_c, cl["o"], {"units": one, "long_name": "order of the "
                                              "line the cluster lies on (NaN: none)"}),
        "order": (("method", "order_index"), order_of,
                  {"units": one, "long_name": "model order of the diagram row (state "
                   "dimension; LSCF: polynomial order)"}),
        "pole_frequency": (dims_p, pf, {"units": "Hz", "long_name":
                                        "natural frequency of each pole per order"}),
        "pole_damping": (dims_p, pz, {"units": one, "long_name":
                                      "damping ratio of each pole per order"}),
        "pole_stable": (dims_p, pstable, {"units": one, "long_name":
                                          "pole matches one of the previous order (1)"}),
        "pole_cluster": (dims_p, pcluster, {"units": one, "long_name":
                                            "cluster index of the pole (-1: none)"}),
        "frf_indicator": (("pairing", "frequency"),
                          np.array([_indicator_db(r) for r in refs]),
                          {"units": "dB", "long_name": "mean normalised FRF magnitude "
                           "squared of the nonparametric estimate"}),
        "coherence": (("pairing", "frequency"),
                      np.array([r.coherence.reshape(f.size, -1).min(axis=1) for r in refs]),
                      {"units": one, "long_name": "lowest coherence over the FRF elements"}),
        "harmonic_order": (("band",), bands.order, {"units": one, "long_name":
                                                    "order of the reference shaft"}),
        "harmonic_low": (("band",), bands.low_hz, {"units": "Hz", "long_name":
                                                   "lower edge of the order line's band"}),
        "harmonic_high": (("band",), bands.high_hz, {"units": "Hz", "long_name":
                                                     "upper edge of the order line's band"}),
    }
    coords = {"method": ("method", methods, {"units": one, "long_name": "diagram method"}),
              "pairing": ("pairing", names, {"units": one, "long_name": "pairing"}),
              "frequency": ("frequency", f, {"units": "Hz", "long_name":
                                             "frequency of the nonparametric estimate"})}
    attrs = {"record": str(record.attrs.get("record", "")),
             "shaft_frequency_low_hz": bands.shaft_hz[0],
             "shaft_frequency_high_hz": bands.shaft_hz[1],
             "speed_source": bands.source or "none",
             "resolution_hz": 1.0 / float(s["nonparametric"]["segment"]),
             "coherence_min": float(s["nonparametric"]["coherence_min"])}
    return xr.Dataset(data, coords, attrs)


def modes_table_rows(ds: xr.Dataset, record: str) -> list[dict[str, Any]]:
    """Rows of ``tables/modes_measured.csv`` (:data:`TABLE_COLUMNS`) of one record's
    :func:`record_modes`: one per cluster, by pairing, method and frequency."""
    rows = []
    for pairing in ds.pairing.values:
        for method in ds.method.values:
            d = ds.sel({"pairing": pairing, "method": method})
            for c in np.flatnonzero(np.isfinite(d.mode_frequency.values)):
                rows.append({"record": record, "pairing": str(pairing),
                             "method": str(method),
                             "frequency_hz": float(d.mode_frequency.values[c]),
                             "damping": float(d.mode_damping.values[c]),
                             "frequency_spread_hz": float(d.mode_frequency_spread.values[c]),
                             "damping_spread": float(d.mode_damping_spread.values[c]),
                             "n_orders": int(d.mode_n_orders.values[c]),
                             "kind": str(d.mode_kind.values[c]),
                             "evidence": str(d.mode_evidence.values[c])})
    return rows
