"""Identification figures: Fig 6 (identified vs true Bode magnitude) and match bandwidths.

:func:`identification_figures` draws both with their report captions from the outputs of
the ``identify`` and ``identification_table`` stages.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.figures.captions import write_caption
from gbpipe.figures.style import db, new, save
from gbpipe.identify import VERSIONS, best_pairings

__all__ = ["fig_bode_identified", "fig_bandwidth", "identification_figures", "version_rank"]


def version_rank(version: str) -> tuple[int, str]:
    """Sort key of a data version: clean, raw, tsa, then the removal methods by name."""
    return (VERSIONS.index(version), "") if version in VERSIONS else (len(VERSIONS), version)


def _draw_case(ax: Any, ax_e: Any, datasets: Sequence[xr.Dataset],
               case: Mapping[str, Any]) -> dict[str, float]:
    # one column of Fig 6: reference, each method's model (with its 95 % band where the
    # identify stage stored one) and the error panel; returns method -> bandwidth [Hz]
    key = f"{case['pairing']}/{case['version']}"
    bws: dict[str, float] = {}
    drawn_ref = False
    colors = {"pbsid": "C0", "moesp": "C1", "n4sid": "C2"}
    for ds in datasets:
        if (ds.attrs["test"], ds.attrs["profile"]) != (case["test"], case["profile"]) \
                or key not in list(ds.model.values):
            continue
        sel = ds.sel(model=key).isel(output=0, input=0)
        f = ds.frequency.values
        if not drawn_ref:
            ax.semilogx(f, db(sel.frf_reference_real.values + 1j * sel.frf_reference_imag.values),
                        "k", lw=2, label=ds.attrs["reference_description"])
            ax.set_ylabel(f"|G| [dB re 1 {sel.frf_unit.values}]")
            drawn_ref = True
        m = ds.attrs["method"]
        tol = float(ds.attrs["tolerance_db"])
        full = ds.sel(model=key)
        status = str(full.status.values)
        if status == "failed":  # no model to draw: the legend says why
            ax.plot([], [], color=colors.get(m), ls="--",
                    label=f"{m.upper()}: failed ({str(full.reason.values)[:60]})")
            continue
        # the drawn element's own band (first output, first input); a MIMO model's
        # all-element band is quoted beside it, named as such
        bw = float(sel.element_match_bandwidth)
        bws[m] = bw
        whole = (f"; all elements {float(full.match_bandwidth):.0f} Hz"
                 if int(full.n_inputs) * int(full.n_outputs) > 1 else "")
        ax.semilogx(f, db(sel.frf_identified_real.values + 1j * sel.frf_identified_imag.values),
                    color=colors.get(m), lw=1.1, ls="--",
                    label=f"{m.upper()} (order {int(sel.order)}, {status}): ±{tol:g} dB to "
                          f"{bw:.0f} Hz{whole}")
        if "frf_identified_lower_db" in sel:
            ax.fill_between(f, sel.frf_identified_lower_db.values,
                            sel.frf_identified_upper_db.values, color=colors.get(m),
                            alpha=0.2, lw=0)
        ax_e.semilogx(f, sel.frf_error.values, color=colors.get(m), lw=1.0)
    tol = float(datasets[0].attrs["tolerance_db"]) if datasets else 1.0
    ax.set_title(f"{case['pairing']} ({case['version']} data)\n{case['test']} "
                 f"{case['profile']}", fontsize=9)
    ax.legend(loc="lower left", fontsize=7)
    ax_e.axhspan(-tol, tol, color="0.85", zorder=0, label=f"±{tol:g} dB")
    ax_e.set_ylim(-10, 10)
    ax_e.set_ylabel("error [dB]")
    ax_e.set_xlabel("frequency [Hz]")
    ax_e.legend(loc="lower left", fontsize=7)
    return bws


def fig_bode_identified(datasets: Sequence[xr.Dataset], cases: Sequence[Mapping[str, Any]],
                        stem: str | os.PathLike) -> list[dict[str, float]]:
    """Bode magnitude of identified models against their reference, one column per case.

    Parameters
    ----------
    datasets : sequence of xarray.Dataset
        ``identify`` outputs (every test, profile and method; each case draws its own).
    cases : sequence of mapping
        ``test``, ``profile``, ``pairing`` and ``version`` of each column (first output,
        first input); e.g. the paper's case (``identify.best``) and the best pairing on
        measured-like data (:func:`gbpipe.identify.best_pairings`).
    stem : path-like
        Output stem (``.png``, and the other formats of :func:`~gbpipe.figures.style.save`).

    Returns
    -------
    list of dict
        Per case: method -> match bandwidth [Hz] of the drawn model.
    """
    fig, axes = new(2, len(cases), figsize=(5.2 * len(cases), 5.6), sharex=True,
                    squeeze=False, gridspec_kw={"height_ratios": [2.2, 1]})
    out = [_draw_case(axes[0, k], axes[1, k], datasets, case)
           for k, case in enumerate(cases)]
    save(fig, stem)
    return out


def fig_bandwidth(rows: Sequence[Mapping[str, Any]], stem: str | os.PathLike,
                  tolerance_db: float) -> None:
    """Heat map of the match bandwidth [Hz] within ``tolerance_db`` [dB]: pairing x version
    (rows) vs variant x method.

    A cell marked × is a pairing the design step predicts not identifiable from that test
    and data version; a failed row (no model, NaN) stays empty.
    """

    ylab = sorted({(r["pairing"], r["version"]) for r in rows},
                  key=lambda k: (k[0], version_rank(k[1])))
    xlab = sorted({(r["test"], r["profile"], r["method"]) for r in rows})
    val = np.full((len(ylab), len(xlab)), np.nan)
    hopeless = set()  # cells the design step predicts not identifiable (0 Hz)
    for r in rows:
        cell = (ylab.index((r["pairing"], r["version"])),
                xlab.index((r["test"], r["profile"], r["method"])))
        val[cell] = float(r["achieved_hz"])
        if r.get("identifiable") == "no":
            hopeless.add(cell)
    fig, ax = new(figsize=(max(6.0, 0.42 * len(xlab) + 2.5), max(4.0, 0.3 * len(ylab) + 1.8)))
    im = ax.imshow(val, aspect="auto", cmap="viridis", vmin=0,
                   vmax=max(100.0, np.nanmax(val) if np.isfinite(val).any() else 100.0))
    for i in range(val.shape[0]):
        for j in range(val.shape[1]):
            if np.isfinite(val[i, j]):
                label = f"{val[i, j]:.0f}" + ("×" if (i, j) in hopeless else "")
                ax.text(j, i, label, ha="center", va="center", fontsize=6,
                        color="w" if val[i, j] < 0.6 * im.get_clim()[1] else "k")
    ax.set_xticks(range(len(xlab)), [f"{t} {p}\n{m}" for t, p, m in xlab], rotation=90,
                  fontsize=6)
    ax.set_yticks(range(len(ylab)), [f"{p} / {v}" for p, v in ylab], fontsize=7)
    ax.grid(False)
    fig.colorbar(im, ax=ax, label=f"match bandwidth (±{tolerance_db:g} dB) [Hz]")
    ax.set_title("Match bandwidth of every identified model")
    save(fig, stem)


def _predicted_numbers(rows: Sequence[Mapping[str, Any]], cases: Sequence[Mapping[str, Any]]
                       ) -> dict[str, str]:
    # the design step's predicted band of each drawn case, for its data version
    out = {}
    keys = ("test", "profile", "pairing", "version")
    for c in cases:
        pred = [float(r["predicted_hz"]) for r in rows
                if tuple(r[k] for k in keys) == tuple(c[k] for k in keys)]
        if pred and np.isfinite(pred[0]):
            out[f"{c['pairing']} on {c['test']} {c['profile']}: predicted band"] = (
                f"{pred[0]:.1f} Hz")
    return out


def identification_figures(datasets: Sequence[xr.Dataset], best: Mapping[str, Any],
                           rows: Sequence[Mapping[str, Any]],
                           out: Mapping[str, str | os.PathLike]) -> list[dict[str, float]]:
    """Fig 6 (the paper's case and the best measured-like case) and the bandwidth map.

    Parameters
    ----------
    datasets : sequence of xarray.Dataset
        ``identify`` outputs of every test, profile and method.
    best : mapping
        ``identify.best``: ``test``, ``profile``, ``pairing`` and ``version`` of the paper's
        case (left column of Fig 6).
    rows : sequence of mapping
        Rows of the ``identification_table`` CSV (``achieved_hz``, ``predicted_hz`` [Hz],
        ``identifiable``, ``pairing``, ``version``, ``test``, ``profile``, ``method``).
    out : mapping
        Output paths by name: ``fig6_png``, ``fig6_caption``, ``bandwidth_png`` and
        ``bandwidth_caption`` (the other formats go beside each PNG).

    Returns
    -------
    list of dict
        Per Fig 6 column: method -> match bandwidth [Hz] of the drawn model.
    """
    tol = float(datasets[0].attrs["tolerance_db"])
    measured = [v for v in {str(r["version"]) for r in rows} if v != "clean"]
    ranked = sorted(best_pairings(rows, measured), key=lambda r: -float(r["achieved_hz"]))
    cases = [dict(best)] + [{k: ranked[0][k] for k in ("test", "profile", "pairing",
                                                        "version")}] * bool(ranked)
    bws = fig_bode_identified(datasets, cases, out["fig6_png"])
    numbers = {f"{c['pairing']} ({c['version']}) {m.upper()}": f"{bw:.1f} Hz"
               for c, b in zip(cases, bws, strict=True) for m, bw in b.items()}
    if ranked:
        numbers["best pairing on measured-like data"] = (
            f"{ranked[0]['pairing']} ({ranked[0]['version']}, {ranked[0]['test']} "
            f"{ranked[0]['profile']}, {ranked[0]['method']}): {ranked[0]['achieved_hz']} Hz; "
            f"runner-up {ranked[0]['runner_up']}")
    write_caption(out["fig6_caption"], "Identified vs true Bode magnitude", "paper Fig. 6",
                  "Left: the paper's case (identify.best), on the data version it names. "
                  "Right: the pairing that reaches the widest band on measured-like data "
                  "(chosen by the numbers over every pairing, test, method and data version "
                  "but clean). Shaded: 95 % bounds of each identified FRF; lower panels: "
                  f"magnitude error with the ±{tol:g} dB band (identify.tolerance_db). A "
                  "failed model is never the right column's (best_pairings); the legend "
                  "gives each model's status. What the data allow is the band the "
                  "design step predicts from the bench model, the excitation and the noise "
                  "(below, and predicted_hz in the identification table).",
                  {**numbers, **_predicted_numbers(rows, cases)})
    fig_bandwidth(rows, out["bandwidth_png"], tol)
    # the widest band of a model that did not fail (a failed row has none: NaN)
    best_row = max((r for r in rows if np.isfinite(float(r["achieved_hz"]))),
                   key=lambda r: float(r["achieved_hz"]),
                   default={k: "none" for k in ("achieved_hz", "pairing", "version", "test",
                                                  "profile", "method")})
    not_identifiable = sorted({f"{r['pairing']} on {r['test']} ({r['version']})"
                               for r in rows if r.get("identifiable") == "no"})
    write_caption(out["bandwidth_caption"],
                  "Match bandwidth across variants, methods, pairings and data versions",
                  "extension (paper section 3 and future work)",
                  f"Highest frequency up to which the identified FRF stays within ±{tol:g} dB "
                  "of the reference, for every test variant, method, signal pairing and data "
                  "version (empty: the identification failed); a cross marks a pairing the "
                  "design step predicts not identifiable from that test and data version "
                  "(its 0 Hz is a limit of the physics, not a failure of the method).",
                  {"widest": f"{best_row['achieved_hz']} Hz ({best_row['pairing']}, "
                             f"{best_row['version']}, {best_row['test']} "
                             f"{best_row['profile']}, {best_row['method']})",
                   "not identifiable (predicted 0 Hz)": ", ".join(not_identifiable) or "none"})
    return bws
