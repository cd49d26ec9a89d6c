"""The identification stage: every pairing x data version of one record, per method.

:func:`identify_methods` fits the models of one job (test, profile; every method) and compares
each with the true FRF and modes of its pairing, read from the model stage's
``truth.nc`` (:func:`gbpipe.model.truth_dataset`): identification depends on data, not on
the model code, and runs unchanged on a measured record (docs/architecture.md, "Stage
graph"). The record is conditioned (decimated, per version) once for all methods, and the
reference of each pairing x version is computed once. A row whose fit raises, or whose
validation fit is not finite, is a failure; a method whose rows all fail raises
:class:`gbpipe.errors.StageError`. :func:`identify_record` is the one-method case.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.errors import StageError
from gbpipe.identify.bench_data import bench_data, bench_sources
from gbpipe.identify.checks import check_signals
from gbpipe.identify.dataset import models_dataset
from gbpipe.identify.fitting import METHODS, fit_model, fit_with_bounds, validation_fit
from gbpipe.identify.harmonic_lines import HarmonicBands, label_poles, record_harmonic_bands
from gbpipe.identify.metrics import identified_modes, match_modes
from gbpipe.identify.orders import order_windows, row_order
from gbpipe.identify.prepare import ConditionedRecord
from gbpipe.identify.reference import (
    Reference,
    nonparametric_reference,
    reference_bandwidth,
    truth_reference,
    within_reference,
)
from gbpipe.identify.status import assess, reference_growth_rate
from gbpipe.io import longest_segment
from gbpipe.progress import Progress

__all__ = ["identify_methods", "identify_record", "record_label"]

log = logging.getLogger("gbpipe")


def _fit_row(res: dict[str, Any], method: str, data: tuple[np.ndarray, ...], dt: float,
             s: Mapping[str, Any]) -> None:
    # fit one pairing x version, score it against its reference; fills `res` in place
    u, y, uv, yv = data
    ref: Reference = res["ref"]
    if s["order"] is None:  # identify.order: stabilization, and the diagram found none
        raise ValueError(s["order_source"])
    if s["bounds"]["groups"] and method in s["bounds"]["methods"]:
        m, lower_db, upper_db = fit_with_bounds(method, u, y, dt, s, ref.frequency)
    else:  # no bounds for this method (identify.bounds)
        m = fit_model(method, u, y, dt, s)
        lower_db = upper_db = np.full((ref.frequency.size, m.C.shape[0], m.B.shape[1]), np.nan)
    g_id = m.frf(ref.frequency)
    err = within_reference(g_id, ref, s["tolerance_db"])
    # the hold-out fit: the lowest over the held-out windows (one per record: a pooled
    # model is as good as its worst repeat); NaN stays NaN
    fit = np.min([validation_fit(m, a, b, int(round(s["fit_segment"] / dt)))
                   for a, b in zip(uv, yv, strict=True)], axis=0)
    fm_id, zm_id = identified_modes(m.A, dt, s["frf"]["f_max"], s["zeta_max"])
    tol = s["tolerance_db"]
    # where the reference cannot judge (an incoherent estimate) the error is NaN: those
    # frequencies are skipped, they do not count as a miss
    f = ref.frequency
    bw = reference_bandwidth(f, err, ref, tol)
    res.update(model=m, g_id=g_id, g_lower_db=lower_db, g_upper_db=upper_db, err=err, fit=fit,
               bandwidth=bw,
               element_bw=np.array([[reference_bandwidth(f, err[:, o, i], ref, tol)
                                     for i in range(err.shape[2])]
                                    for o in range(err.shape[1])]),
               modes_id=fm_id, zeta_id=zm_id,
               modes_matched=match_modes(ref.modes, fm_id))
    # the evidence the match band rests on: assessable frequencies inside it
    n_points = int(np.sum(ref.assessable & (f <= bw)))
    res["verdict"] = assess(m, fit, n_points, reference_growth_rate(ref.modes, ref.damping), s)


def identify_record(cfg: Mapping[str, Any], record: xr.Dataset,
                    validation: xr.Dataset | None, truth: xr.Dataset | None, method: str,
                    removed: Mapping[str, tuple[xr.Dataset, xr.Dataset | None]]
                    | None = None, **kwargs: Any) -> xr.Dataset:
    """Identify every configured pairing x data version of one record with one method.

    :func:`identify_methods` with ``methods=(method,)`` (``kwargs``: its ``orders``,
    ``order_source``, ``validation_window``, ``line_orders``); the parameters, return
    value and errors are those of one of its methods.
    """
    return identify_methods(cfg, record, validation, truth, (method,), removed,
                            **kwargs)[method]


def identify_methods(cfg: Mapping[str, Any], record: xr.Dataset | Sequence[xr.Dataset],
                     validation: xr.Dataset | None, truth: xr.Dataset | None,
                     methods: Sequence[str],
                     removed: Mapping[str, tuple[xr.Dataset, xr.Dataset | None]]
                     | Sequence[Mapping[str, tuple[xr.Dataset, None]]] | None = None,
                     orders: Mapping[str, int] | None = None,
                     order_source: Mapping[str, str] | None = None,
                     validation_window: tuple[float, float]
                     | Sequence[tuple[float, float] | None] | None = None,
                     line_orders: Sequence[float] = ()) -> dict[str, xr.Dataset]:
    """Identify every configured pairing x data version of one record with each method.

    Parameters
    ----------
    cfg : mapping
        Validated configuration slice: ``campaign.settle`` and the ``identify`` section.
    record : xarray.Dataset or sequence of xarray.Dataset
        The record identified: simulated (:func:`gbpipe.simulate.test`) or measured
        (:func:`gbpipe.measured.read`); or the repeats of one bench test (``group:`` in
        ``measured:``, their ``group`` attribute names the output), pooled: one
        nonparametric estimate with every record's averages and one multi-experiment
        model (:mod:`gbpipe.identify.bench_data`).
    validation : xarray.Dataset or None
        The record the fit % is computed on (never used for fitting). None: a window of
        ``record`` is held out instead (``validation_window``).
    truth : xarray.Dataset or None
        The model stage's ``truth.nc`` (true FRFs on the identification grid, modes). None
        for a measured record: each model is scored against the nonparametric FRF of the
        same data in its coherent band (:mod:`gbpipe.identify.reference`).
    methods : sequence of {"pbsid", "moesp", "n4sid"}
        The methods, each fitted on the same conditioned data.
    removed : mapping str -> (xarray.Dataset, xarray.Dataset or None), optional
        Per harmonic-removal version (``tsa``, ``vkf``, ...): the record and the
        validation record after that removal (``removal_tests``
        outputs; the second None without a validation record). Required for every
        version in ``identify.versions`` but ``clean`` and ``raw``. Pooled records: one
        such mapping per record.
    orders : mapping str -> int, optional
        Model order per pairing name (e.g. from the record's stabilization diagram:
        :func:`gbpipe.identify.orders.stabilization_orders`); a pairing absent from it is
        fitted with ``identify.order`` (``stabilization`` without an order: its rows
        fail, saying why: :func:`gbpipe.identify.orders.row_order`).
    order_source : mapping str -> str, optional
        Where each order of ``orders`` came from (stored per model as ``order_source``).
    validation_window : (float, float), or a sequence of them (or None) per pooled record
        Without ``validation``: the held-out ``start, end`` [s from the record start]
        (``measured.<record>.validation``); default: the latest ``identify.holdout`` of
        the record holding ``identify.holdout_power_min`` of the inputs' band power
        (:mod:`gbpipe.identify.windows`). The operating point of such a record is its mean
        before the inputs' first excitation (at most ``campaign.settle``).
    line_orders : sequence of float, optional
        A bench record's excitation orders of its tacho shaft (``measured.<record>.
        orders``) besides the shaft harmonics ``1 .. identify.stabilization.
        shaft_harmonics``. Without a truth, the nonparametric reference does not judge a
        model inside these lines' bands over the record's speed range: a line that
        reaches input and output biases the estimate there, whatever its coherence.

    Returns
    -------
    dict of str -> xarray.Dataset
        Per method, :func:`gbpipe.identify.models_dataset`; ``status`` is ok, poor or
        failed and ``reason`` says why (:mod:`gbpipe.identify.status`); the ``reference``
        attribute says what the FRFs were scored against.

    Raises
    ------
    ValueError
        An unknown method, or a removal version without its records in ``removed``.
    gbpipe.errors.DataError
        Before any fit: an input, output or reference signal without variance, or an
        input without power in the identified band (:func:`gbpipe.identify.checks.
        check_signals`).
    gbpipe.errors.StageError
        Every row of a method failed (the message lists each failure).
    """
    s = cfg["identify"]
    pooled = not isinstance(record, xr.Dataset)
    # a split bench record: its longest piece
    records = [longest_segment(r) for r in (record if pooled else [record])]
    for method in methods:
        if method not in METHODS:
            raise ValueError(f"unknown method {method!r}; use {', '.join(METHODS)}")
    if pooled and (validation is not None or truth is not None):
        raise ValueError("pooled records are bench records: no validation record, no truth")
    removed_all = [dict(r) for r in (removed or [{}] * len(records))] if pooled else \
        [dict(removed or {})]
    for version in s["versions"]:
        if version in ("clean", "raw"):
            continue
        if any(version not in rem or (validation is not None and rem[version][1] is None)
               for rem in removed_all):
            raise ValueError(f"version {version!r} needs the record and validation record "
                             f"after that harmonic removal (removed[{version!r}])")
    fs_id = float(s["sample_rate"])
    dt = 1.0 / fs_id
    where, band = _label(records), (s["frf"]["f_min"], s["frf"]["f_max"])
    first, settle = s["versions"][0], float(cfg["campaign"]["settle"])
    grid = (float(records[0].attrs["sample_rate"]), settle, fs_id, s["lowpass"])
    notes: dict[str, str] = {}
    sources = None
    if validation is None:  # bench records: operating point and hold-out from their data
        wins = (list(validation_window or [None] * len(records)) if pooled
                else [validation_window])
        sources = bench_sources(records, [{v: tr for v, (tr, _) in rem.items()}
                                          for rem in removed_all], settle, s, wins)
        for key in ("operating_point", "validation_test"):
            notes[key] = "; ".join(f"{src.name}: {src.notes[key]}" if pooled
                                   else src.notes[key] for src in sources)
        if pooled:
            notes["records"] = ",".join(src.name for src in sources)
        conditioned = [src.rec for src in sources]
    else:  # each (record, version, signal) is conditioned once for all pairings and methods
        rem = removed_all[0]
        conditioned = [ConditionedRecord(records[0], {v: tr for v, (tr, _) in rem.items()},
                                         *grid)]
        val = ConditionedRecord(validation, {v: tv for v, (_, tv) in rem.items()}, *grid)
    min_len = 2 * (int(s["past"]) + int(s["future"]))

    # a bench record's order lines, where its nonparametric reference judges no model
    bands = _line_bands(records, line_orders, s) if truth is None else []
    def row_data(p: Mapping[str, Any], version: str) -> tuple:
        """(u, y, held-out u, held-out y) of a pairing and version, from the conditioned
        columns (each conditioned once): copies, made per row (of an hour-long record the
        rows' copies together would hold 8 pairing x version data sets)."""
        if sources:  # fit on the rest of every record, in pieces (multi-experiment)
            u, uv = bench_data(sources, p["inputs"], version, min_len)
            y, yv = bench_data(sources, p["outputs"], version, min_len)
            return u, y, uv, yv
        return (conditioned[0](p["inputs"], version), conditioned[0](p["outputs"], version),
                [val(p["inputs"], version)], [val(p["outputs"], version)])

    rows = []  # (pairing, version, reference): what every method fits and is scored on
    progress = Progress(log, "conditioning and nonparametric FRF of every pairing x version",
                        len(s["pairings"]) * len(s["versions"]))
    for p in s["pairings"]:
        ref_truth = truth_reference(truth, p, records[0]) if truth is not None else None
        # unusable signals are refused here, before any fit (checks.py)
        for rec in conditioned:
            check_signals(where, p["inputs"], rec(p["inputs"], first), "input", fs_id, band)
            check_signals(where, p["outputs"], rec(p["outputs"], first), "output", fs_id)
            if "reference" in p:
                check_signals(where, p["reference"], rec(p["reference"], "raw"),
                              "reference", fs_id)
        # a mapped set-point of a closed-loop bench record: the nonparametric estimate
        # goes through it, free of the feedback's bias (its version is immaterial)
        r = None
        if "reference" in p:
            r = (bench_data(sources, p["reference"], "raw", min_len)[0] if sources
                 else conditioned[0](p["reference"], "raw"))
        for version in s["versions"]:
            u, y, _, _ = data = row_data(p, version)
            ref = ref_truth or _off_lines(nonparametric_reference(u, y, fs_id, s, r), bands)
            rows.append((p, version, ref))
            progress(len(rows), f"{p['name']}/{version}")
            del u, y, data  # made again for the fits: one row's copies at a time

    # every method on one row before the next row: MOESP and N4SID of one data set share its
    # window products (gbpipe.sysid remembers them: gbpipe.memo)
    results: dict[str, list[dict[str, Any]]] = {method: [] for method in methods}
    progress = Progress(log, f"{', '.join(methods)} on every pairing x version",
                        len(rows) * len(methods))
    for p, version, ref in rows:
        data = row_data(p, version)
        order, source = row_order(s, p["name"], orders, order_source)
        s_row = {**s, "order": order, "order_source": source,
                 **order_windows(s, order, len(p["outputs"]))}
        for method in methods:
            res = _identify_row(method, p, version, data, ref, dt, s_row)
            results[method].append({**res, "order_source": source})
            progress(sum(map(len, results.values())), f"{method} {p['name']}/{version}")
    return {method: _method_dataset(method, results[method], dt, s, records, validation, notes)
            for method in methods}


def _line_bands(records: Sequence[xr.Dataset], line_orders: Sequence[float],
                s: Mapping[str, Any]) -> list[HarmonicBands]:
    """The order-line bands of each of ``records`` (none without a tachometer).

    :func:`gbpipe.identify.harmonic_lines.record_harmonic_bands`, widened by the main-lobe
    half-width of the nonparametric estimate's Hann window, ``2 / segment``: that far a
    line leaks into the Welch estimate. Computed once per job, before any fit. A record
    without a tachometer gets none here (its lines are placed by the modes stage from a
    speed signal or the record's own order-1 line, docs/modal.md).
    """
    resolution = 2.0 / float(s["nonparametric"]["segment"])
    if len(line_orders) and any("pulse_time" not in rec for rec in records):
        log.warning("orders %s not excluded from the assessment of a record without a "
                    "tachometer (docs/modal.md)", list(line_orders))
    return [record_harmonic_bands(rec, line_orders, resolution,
                                  s["stabilization"]["shaft_harmonics"], s["frf"]["f_max"],
                                  segment=float(s["nonparametric"]["segment"]))
            for rec in records if "pulse_time" in rec]


def _off_lines(ref: Reference, bands: Sequence[HarmonicBands]) -> Reference:
    # the nonparametric reference judges nothing on an order line (see line_orders)
    on = np.zeros(ref.frequency.shape, dtype=bool)
    for b in bands:
        on |= label_poles(ref.frequency, b) == "harmonic"
    return ref._replace(assessable=ref.assessable & ~on)


def _identify_row(method: str, p: Mapping[str, Any], version: str,
                  data: tuple[np.ndarray, ...], ref: Reference, dt: float,
                  s: Mapping[str, Any]) -> dict[str, Any]:
    # one pairing x version with one method: its result, "ok" or why it failed
    res = {"pairing": p["name"], "version": version, "inputs": list(p["inputs"]),
           "outputs": list(p["outputs"]), "ref": ref, "model": None}
    try:
        _fit_row(res, method, data, dt, s)
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
        res.update(model=None,
                   verdict=assess(None, None, 0, 0.0, s, f"{type(exc).__name__}: {exc}"))
    res["status"], res["reason"] = res["verdict"].status, res["verdict"].reason
    if res["status"] == "failed":
        log.warning("%s %s/%s failed: %s", method, p["name"], version, res["reason"])
    else:
        log.info("%s %-14s %-5s order %2d: bandwidth %6.1f Hz (vs %s), fit %s %%: %s (%s)",
                 method, p["name"], version, res["model"].order, res["bandwidth"],
                 ref.kind, np.round(res["fit"], 1), res["status"], res["reason"])
    return res


def _method_dataset(method: str, results: list[dict[str, Any]], dt: float,
                    s: Mapping[str, Any], records: Sequence[xr.Dataset],
                    validation: xr.Dataset | None, notes: Mapping[str, str]) -> xr.Dataset:
    # the method's dataset from its rows; every row failed: StageError
    if all(r["status"] == "failed" for r in results):
        failures = "\n".join(f"  {r['pairing']}/{r['version']}: {r['reason']}" for r in results)
        raise StageError(f"identify {method} on {_label(records)}: all {len(results)} "
                         f"identifications failed:\n{failures}")
    ds = models_dataset(results, dt, method, s, records[0], validation)
    ds.attrs.update(notes)  # bench records: operating point, hold-out window, records
    if len(records) > 1:  # pooled repeats: the file is named by their group
        ds.attrs["test"] = str(records[0].attrs.get("group", ds.attrs["test"]))
    return ds


def _label(records: Sequence[xr.Dataset]) -> str:
    # one record's label, or the pooled group's with its records
    if len(records) == 1:
        return record_label(records[0])
    names = ", ".join(str(r.attrs.get("record", "?")) for r in records)
    return f"group {records[0].attrs.get('group', '?')} (records {names})"


def record_label(record: xr.Dataset) -> str:
    """``test (profile)`` of a simulated record, ``record <name>`` of a measured one."""
    if "record" in record.attrs:
        return f"record {record.attrs['record']}"
    return f"{record.attrs.get('test', '?')} ({record.attrs.get('profile', '?')})"
