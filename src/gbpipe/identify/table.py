"""Rows of ``identification.csv`` from the stored identify outputs (nothing recomputed
but summaries of what the NetCDF files hold)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

__all__ = ["SHORT", "table_rows", "best_pairings"]

#: Short names of the pairing signals (table and figure labels).
SHORT = {"motor_torque_driver": "Tdrv", "motor_torque_driven": "Tdrn",
         "speed_gb2_hss": "wdrv", "speed_gb1_hss": "wdrn", "speed_lss": "wlss",
         "torque_meter_driving": "Mdrv", "torque_meter_driven": "Mdrn"}


#: The variables of an identify output that :func:`table_rows` reads.
_ROW_VARIABLES = ("n_inputs", "n_outputs", "input_name", "output_name", "fit",
                  "element_match_bandwidth", "mode_true", "mode_matched", "pairing", "version",
                  "order", "match_bandwidth", "reference_band_max", "status", "stable",
                  "reason", "frf_error", "assessable")


def _short(names: Sequence[str]) -> str:
    return "+".join(SHORT.get(n, n) for n in names)


def _within_pct(sel: Mapping[str, np.ndarray], ny: int, nu: int, tol: float) -> float:
    # share of the frequencies the reference can assess where every element is within
    # tolerance (an incoherent estimate's frequencies are not counted)
    err = np.abs(sel["frf_error"][:, :ny, :nu])
    band = sel["assessable"] > 0.5
    if not band.any():
        return float("nan")
    return float(100.0 * np.mean(np.all(err[band] <= tol, axis=(1, 2))))


def _predicted(designs: Mapping[tuple[str, str], xr.Dataset], ds: xr.Dataset,
               pairing: str, version: str) -> float:
    # the design step's predicted band of this pairing and data version on this record
    # (NaN: no prediction)
    design = designs.get((ds.attrs["test"], ds.attrs["profile"]))
    if (design is None or pairing not in list(design.pairing.values)
            or version not in list(design.version.values)):
        return float("nan")
    return float(design.predicted_hz.sel(pairing=pairing, version=version))


def table_rows(datasets: Sequence[xr.Dataset],
               designs: Mapping[tuple[str, str], xr.Dataset] | None = None
               ) -> list[dict[str, Any]]:
    """Rows of ``identification.csv``: one per test x profile x method x pairing x version.

    Every number is read from the datasets (what the NetCDF files store).
    ``achieved_hz`` is the match bandwidth against ``reference``; ``predicted_hz`` the
    band the design step (:mod:`gbpipe.identify.design`) expected for that data version
    from the bench model, the excitation and the noise, before identification ran (NaN
    without a design file);
    ``identifiable`` says ``no`` where that prediction is 0 Hz, so that a 0 Hz achieved
    bandwidth there reads as a limit of the physics, not a failure of the method. Rows of
    the ``tsa`` version also say how much of the clean-data bandwidth harmonic removal
    recovers: ``100 (bw_tsa - bw_raw) / (bw_clean - bw_raw)`` when clean beats raw.

    Parameters
    ----------
    datasets : sequence of xarray.Dataset
        ``identify`` outputs.
    designs : mapping (test, profile) -> xarray.Dataset, optional
        ``design`` outputs (``predicted_hz`` per version and pairing).
    """
    designs = dict(designs or {})
    rows = []
    for ds in datasets:
        # the variables a row reads, as numpy arrays once: an xarray selection per model
        # (of every FRF of the file) and per field was most of the table's time
        arrays = {v: ds[v].values for v in _ROW_VARIABLES if v in ds}
        for k in range(ds.sizes["model"]):
            sel = {v: a[k] for v, a in arrays.items()}
            nu, ny = int(sel["n_inputs"]), int(sel["n_outputs"])
            ins = [str(x) for x in sel["input_name"][:nu]]
            outs = [str(x) for x in sel["output_name"][:ny]]
            fit = sel["fit"][:ny]
            ebw = sel["element_match_bandwidth"][:ny, :nu]
            mt = sel["mode_true"]
            mm = sel["mode_matched"]
            ok = np.isfinite(mt)
            rel = np.abs(mm[ok] - mt[ok]) / mt[ok]
            pred = _predicted(designs, ds, str(sel["pairing"]), str(sel["version"]))
            rows.append({
                "test": ds.attrs["test"], "profile": ds.attrs["profile"],
                "method": ds.attrs["method"], "pairing": str(sel["pairing"]),
                "version": str(sel["version"]), "inputs": _short(ins),
                "outputs": _short(outs), "validation": ds.attrs["validation_test"],
                "order": int(sel["order"]), "achieved_hz": float(sel["match_bandwidth"]),
                "predicted_hz": pred,
                "identifiable": "unknown" if np.isnan(pred) else ("yes" if pred > 0 else "no"),
                # what the bandwidth is measured against, and up to where it could be
                "reference": ds.attrs["reference"],
                "reference_band_hz": float(sel["reference_band_max"]),
                "element_bandwidth_hz": ";".join(
                    f"{SHORT.get(outs[o], outs[o])}<-{SHORT.get(ins[i], ins[i])}:"
                    f"{ebw[o, i]:.4g}" for o in range(ny) for i in range(nu)),
                # a failed row claims no share either (its model, if any, is unusable)
                "within_tol_pct": (float("nan") if str(sel["status"]) == "failed"
                                   else _within_pct(sel, ny, nu, ds.attrs["tolerance_db"])),
                "fit_pct": float(np.mean(fit)) if np.all(np.isfinite(fit)) else float("nan"),
                "fit_min_pct": float(np.min(fit)) if np.all(np.isfinite(fit)) else float("nan"),
                # the status's criterion (gbpipe.identify.status); unknown without a model
                "stable": ("unknown" if not np.isfinite(float(sel["stable"]))
                           else bool(float(sel["stable"]) > 0.5)),
                "modes_true": int(ok.sum()),
                "modes_within_tol": int(np.sum(rel <= ds.attrs["mode_tolerance"])),
                "status": str(sel["status"]),
                "reason": str(sel["reason"]),
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
        gain = clean["achieved_hz"] - raw["achieved_hz"]
        r["recovered_bandwidth_pct"] = (
            100.0 * (r["achieved_hz"] - raw["achieved_hz"]) / gain
            if gain > 0 else float("nan"))
    return rows


def _rank(r: Mapping[str, Any]) -> tuple[int, float, float]:
    # ok before poor; then the achieved band, then the fit (NaN ranks last, never first)
    def num(key: str) -> float:
        x = float(r[key])
        return x if np.isfinite(x) else -np.inf

    return int(str(r["status"]) == "ok"), num("achieved_hz"), num("fit_pct")


def best_pairings(rows: Sequence[Mapping[str, Any]], versions: Sequence[str]
                  ) -> list[dict[str, Any]]:
    """The best pairing of each motor torque by the numbers, not by choice.

    For each input (a motor torque, or both for MIMO) the SISO or MIMO pairing whose
    identified model reaches the widest achieved bandwidth over every test, profile and
    method of the given data versions; ``ok`` models rank before ``poor`` ones, ``failed``
    rows are never chosen, ties go to the higher fit %, and a NaN number ranks below every
    finite one.

    Parameters
    ----------
    rows : sequence of mapping
        :func:`table_rows` rows (or the CSV read back: numbers may be strings).
    versions : sequence of str
        Data versions considered (e.g. the measured-like ones: everything but ``clean``).

    Returns
    -------
    list of dict
        One row per input set that has a model which did not fail: the winning row's keys,
        and ``runner_up`` (pairing, its achieved bandwidth [Hz] and status) so the margin
        is visible.
    """
    out = []
    for inputs in sorted({str(r["inputs"]) for r in rows}):
        cand = [r for r in rows if r["inputs"] == inputs and r["version"] in versions
                and str(r["status"]) in ("ok", "poor")]
        if not cand:
            continue
        # the best model of each pairing, then the pairings ranked
        per_pairing: dict[str, Mapping[str, Any]] = {}
        for r in cand:
            p = str(r["pairing"])
            if p not in per_pairing or _rank(r) > _rank(per_pairing[p]):
                per_pairing[p] = r
        ranked = sorted(per_pairing.values(), key=_rank, reverse=True)
        best = dict(ranked[0])
        best["runner_up"] = (f"{ranked[1]['pairing']}: {float(ranked[1]['achieved_hz']):.4g} Hz"
                             f" ({ranked[1]['status']})" if len(ranked) > 1 else "none")
        out.append(best)
    return out
