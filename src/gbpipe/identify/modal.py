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

Both are fitted again on the data decimated further (zoom, :func:`zoom_bands`), and each
diagram is read as one joined over those bands: a model of a few dozen states over
0-Nyquist fits the low end of the band poorly (docs/modal.md, "Zoomed diagrams").

Each cluster of stable poles is judged ``mode``, ``harmonic`` (an order line) or
``spurious`` (noise fitted) by :mod:`gbpipe.identify.mode_kinds`; a subspace cluster on
an order line is weighed against the LSCF diagram of the same pairing, which fits the FRF
from the measured input alone. The subspace diagram's order (the lowest that holds every
cluster, harmonics included: the identify stage's model must explain the lines too) is
``model_order``, which the identify stage of the record uses. docs/modal.md.
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
from gbpipe.identify.modal_diagrams import Diagram, diagrams, order_range, zoom_bands
from gbpipe.identify.mode_kinds import Evidence
from gbpipe.identify.prepare import ConditionedRecord
from gbpipe.identify.record_kinds import Cluster, PairingData, record_evidence
from gbpipe.identify.reference import Reference, nonparametric_reference
from gbpipe.io import longest_segment
from gbpipe.lti import pad
from gbpipe.sysid import held_modes, lowest_order

__all__ = ["record_modes", "modes_table_rows", "TABLE_COLUMNS", "order_range"]

log = logging.getLogger("gbpipe")

#: Columns of ``tables/modes_measured.csv``, in order.
TABLE_COLUMNS = ("record", "pairing", "method", "frequency_hz", "damping",
                 "frequency_spread_hz", "damping_spread", "n_orders", "kind", "evidence")


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
    results, own, refs, data = [], [], [], []
    angle = reference_angle(record, rec.times(), speeds) if speed else None  # of the lines
    for p in s["pairings"]:
        u, y = rec(p["inputs"], "raw"), rec(p["outputs"], "raw")
        r = rec(p["reference"], "raw") if "reference" in p else None
        refs.append(nonparametric_reference(u, y, fs_id, s, r))
        data.append(PairingData(y, list(p["outputs"]), fs_id, refs[-1].frequency,
                                refs[-1].coherence.reshape(refs[-1].frequency.size, -1)
                                .max(axis=1), angle))
        own.append(diagrams(u, y, r, fs_id, s, p["name"]))
        results.append({m: d if isinstance(d, str) else d.joined for m, d in own[-1].items()})
        for method, res in results[-1].items():
            if isinstance(res, str):
                log.warning("%s %s: %s", p["name"], method, res)
            else:
                log.info("%s %s: %d clusters", p["name"], method, len(res.clusters))
    kept = _in_band(s, results)
    frf = [_frf_clusters(res) for res in results]  # per pairing; LSCF's own: not asked
    clusters = [Cluster(j, m.frequency_hz, m.damping, None if method == "lscf" else frf[j])
                for (method, j), ms in kept.items() for _, m in ms]
    evidence, bands = record_evidence(
        clusters, data, bands, orders, resolution,
        float(s["nonparametric"]["coherence_min"]), st["shaft_harmonics"],
        s["frf"]["f_max"], int(cfg.get("seed", 0)),
        {} if speed else _turning_shafts(record, 1.0 / resolution))
    return _dataset(s, [p["name"] for p in s["pairings"]], results, own, refs, bands,
                    record, kept, evidence)


def _frf_clusters(by_method: Mapping[str, Any]) -> np.ndarray | None:
    # what a subspace cluster on an order line must meet to be a mode (mode_kinds): the
    # frequencies [Hz] of the clusters and candidates of one pairing's LSCF diagram, from
    # its joined diagrams by method (diagrams() gives LSCF's or the reason it failed);
    # None where it failed: nothing to meet
    lscf = by_method["lscf"]
    if isinstance(lscf, str):
        return None
    return np.array([m.frequency_hz for m in (*lscf.clusters, *lscf.candidates)])


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
             own: list[dict[str, Diagram | str]], refs: list[Reference], bands: HarmonicBands,
             record: xr.Dataset,
             kept: Mapping[tuple[str, int], list[tuple[int, Any]]],
             evidence: Sequence[Evidence]) -> xr.Dataset:
    methods = list(results[0])
    nm, npair = len(methods), len(names)
    f_lo, f_hi = float(s["frf"]["f_min"]), float(s["frf"]["f_max"])
    n_cl = max([len(k) for k in kept.values()] + [1])
    n_ord = max(len(order_range(s["stabilization"][k], st))
                for k, st in (("orders", s["stabilization"]["step"]), ("lscf_orders", 1)))
    n_pole = max([len(p[0]) for res in own for d in res.values() if not isinstance(d, str)
                  for r in (d.joined, d.own) for p in r.poles] + [1])
    shape_c, shape_p = (nm, npair, n_cl), (nm, npair, n_ord, n_pole)
    cl = {k: np.full(shape_c, np.nan) for k in ("f", "z", "fs", "zs", "n", "k", "kl", "c", "o",
                                                 "q")}
    tol = s["stabilization"]["frequency_tolerance"]
    kind = np.full(shape_c, "", dtype=object)
    why = np.full(shape_c, "", dtype=object)
    pf, pz, pm = (np.full(shape_p, np.nan) for _ in range(3))
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
            cl["q"][i, j, c] = q = own[j][method].decimation(m.frequency_hz, tol)
            if q > 1:
                why[i, j, c] += (f"; from the diagram of the data decimated {q}x "
                                 f"({float(s['sample_rate']) / q:g} Hz, zoom)")
        renumber = np.full(len(r.clusters) + 1, -1)  # stab's cluster -> kept; -1 stays
        renumber[[k for k, _ in keep]] = np.arange(len(keep))
        pf[i, j, :len(r.poles)] = _ragged([p[0] for p in r.poles], n_pole)
        pz[i, j, :len(r.poles)] = _ragged([p[1] for p in r.poles], n_pole)
        pstable[i, j, :len(r.poles)] = _ragged(r.stable, n_pole, 0)
        pcluster[i, j, :len(r.poles)] = _ragged([renumber[lab] for lab in r.labels],
                                                n_pole, -1)
    for j, res in enumerate(own):
        # the order the identify stage fits: the lowest of the diagram at its rate (not
        # zoomed) that holds every mode either method found in the band and the order
        # lines of that diagram (the model must explain the lines it is fitted on; a
        # zoomed band's line clusters sit elsewhere on a sweeping line than its poles);
        # noise poles never count, and lines alone (no mode) set no order
        modes = cl["f"][:, j][kind[:, j] == "mode"]
        for i, method in enumerate(methods):
            if isinstance(res[method], str):
                status[i, j] = res[method]
                continue
            r = res[method].own
            order_of[i, :len(r.orders)] = r.orders
            pm[i, j, :len(r.poles)] = _ragged([p[0] for p in r.poles], n_pole)
            wanted = np.concatenate([modes, cl["f"][i, j][(kind[i, j] == "harmonic")
                                                          & (cl["q"][i, j] == 1)]])
            held = held_modes(r.poles, wanted, tol)
            model_order[i, j] = modes.size and lowest_order(r.orders, r.poles, wanted[held], tol)
            missing = np.unique(np.round(modes[~held[:modes.size]], 1))
            if not modes.size:
                status[i, j] = (f"no mode: no cluster of stable poles in {f_lo:g}-{f_hi:g} Hz "
                                "that is a mode (table evidence)")
            elif missing.size:
                status[i, j] = (f"poor: no order up to {int(r.orders[-1])} at "
                                f"{float(s['sample_rate']):g} Hz holds the mode(s) at "
                                f"{missing.tolist()} Hz (of the other method "
                                "or of a zoomed band)")
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
        "mode_kurtosis": (dims_c, cl["k"], {"units": one, "long_name": "kurtosis in the "
                                            "cluster's band of the output lowest against "
                                            "its limit (of those whose sinusoid is the "
                                            "pole's, where any)"}),
        "mode_kurtosis_limit": (dims_c, cl["kl"], {"units": one, "long_name": "lowest "
                                                   "kurtosis a mode of the cluster (or a "
                                                   "lighter one in its band) gives there"}),
        "mode_coherence": (dims_c, cl["c"], {"units": one, "long_name": "highest coherence "
                                             "in the cluster's band"}),
        "mode_line_order": (dims_c, cl["o"], {"units": one, "long_name": "order of the "
                                              "line the cluster lies on (NaN: none)"}),
        "mode_decimation": (dims_c, cl["q"], {"units": one, "long_name": "decimation of "
                                              "the diagram the cluster was read from, "
                                              "relative to the identification rate (1: "
                                              "its own; zoom)"}),
        "order": (("method", "order_index"), order_of,
                  {"units": one, "long_name": "model order of the diagram row (state "
                   "dimension; LSCF: polynomial order)"}),
        "pole_frequency": (dims_p, pf, {"units": "Hz", "long_name":
                                        "natural frequency of each pole per order"}),
        "model_pole_frequency": (dims_p, pm, {"units": "Hz", "long_name":
                                              "natural frequency of each pole per order "
                                              "of the diagram at the identification rate "
                                              "(not zoomed): the model order's"}),
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
        "zoom_edge_frequency": (
            ("zoom_edge",), [b[2] for b in zoom_bands(s, float(s["sample_rate"]))[1:]],
            {"units": "Hz", "long_name": "frequency below which the diagram's poles come "
             "from the data decimated further (zoom), but near the identification rate's "
             "own clusters"}),
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
