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
from gbpipe.figures.style import new, save
from gbpipe.identify import VERSIONS

__all__ = ["fig_bode_identified", "fig_bandwidth", "identification_figures", "version_rank"]


def version_rank(version: str) -> tuple[int, str]:
    """Sort key of a data version: clean, raw, tsa, then the removal methods by name."""
    return (VERSIONS.index(version), "") if version in VERSIONS else (len(VERSIONS), version)


def _db(re: np.ndarray, im: np.ndarray) -> np.ndarray:
    return 20 * np.log10(np.maximum(np.hypot(re, im), 1e-300))


def fig_bode_identified(datasets: Sequence, best: Mapping[str, Any],
                        stem: str | os.PathLike) -> dict[str, float]:
    """Bode magnitude of the best case: true model and each method's identified model.

    Parameters
    ----------
    datasets : sequence of xarray.Dataset
        ``identify`` outputs of the best case's test and profile (one per method).
    best : mapping
        ``identify.best``: ``pairing`` and ``version`` drawn (first output, first input).
    stem : path-like
        Output stem (``.png`` and ``.pdf``).

    Returns
    -------
    dict
        Method -> match bandwidth [Hz] of the drawn model.
    """

    fig, (ax, ax_e) = new(2, 1, figsize=(7.0, 5.6), sharex=True,
                          gridspec_kw={"height_ratios": [2.2, 1]})
    key = f"{best['pairing']}/{best['version']}"
    bws: dict[str, float] = {}
    drawn_true = False
    colors = {"pbsid": "C0", "moesp": "C1", "n4sid": "C2"}
    for ds in datasets:
        if key not in list(ds.model.values):
            continue
        sel = ds.sel(model=key).isel(output=0, input=0)
        f = ds.frequency.values
        if not drawn_true:
            ax.semilogx(f, _db(sel.frf_reference_real.values, sel.frf_reference_imag.values),
                        "k", lw=2, label=ds.attrs["reference_description"])
            drawn_true = True
        m = ds.attrs["method"]
        bw = float(sel.match_bandwidth)
        bws[m] = bw
        ax.semilogx(f, _db(sel.frf_identified_real.values, sel.frf_identified_imag.values),
                    color=colors.get(m), lw=1.1, ls="--",
                    label=f"{m.upper()} (order {int(sel.order)}): 1 dB to {bw:.0f} Hz")
        ax_e.semilogx(f, sel.frf_error.values, color=colors.get(m), lw=1.0)
    ax.set_ylabel("|G| [dB re 1 rad/s per N·m]")
    ax.set_title(f"{best['pairing']} ({best['version']} data), {best['test']} "
                 f"{best['profile']}: identified vs true")
    ax.legend(loc="lower left")
    ax_e.axhspan(-1, 1, color="0.85", zorder=0, label="±1 dB")
    ax_e.set_ylim(-10, 10)
    ax_e.set_ylabel("error [dB]")
    ax_e.set_xlabel("frequency [Hz]")
    ax_e.legend(loc="lower left")
    save(fig, stem)
    return bws


def fig_bandwidth(rows: Sequence[Mapping[str, Any]], stem: str | os.PathLike) -> None:
    """Heat map of the match bandwidth: pairing x version (rows) vs variant x method."""

    ylab = sorted({(r["pairing"], r["version"]) for r in rows},
                  key=lambda k: (k[0], version_rank(k[1])))
    xlab = sorted({(r["test"], r["profile"], r["method"]) for r in rows})
    val = np.full((len(ylab), len(xlab)), np.nan)
    for r in rows:
        val[ylab.index((r["pairing"], r["version"])),
            xlab.index((r["test"], r["profile"], r["method"]))] = float(r["match_bandwidth_hz"])
    fig, ax = new(figsize=(max(6.0, 0.42 * len(xlab) + 2.5), max(4.0, 0.3 * len(ylab) + 1.8)))
    im = ax.imshow(val, aspect="auto", cmap="viridis", vmin=0,
                   vmax=max(100.0, np.nanmax(val) if np.isfinite(val).any() else 100.0))
    for i in range(val.shape[0]):
        for j in range(val.shape[1]):
            if np.isfinite(val[i, j]):
                ax.text(j, i, f"{val[i, j]:.0f}", ha="center", va="center", fontsize=6,
                        color="w" if val[i, j] < 0.6 * im.get_clim()[1] else "k")
    ax.set_xticks(range(len(xlab)), [f"{t} {p}\n{m}" for t, p, m in xlab], rotation=90,
                  fontsize=6)
    ax.set_yticks(range(len(ylab)), [f"{p} / {v}" for p, v in ylab], fontsize=7)
    ax.grid(False)
    fig.colorbar(im, ax=ax, label="match bandwidth (±1 dB) [Hz]")
    ax.set_title("Match bandwidth of every identified model")
    save(fig, stem)


def identification_figures(datasets: Sequence[xr.Dataset], best: Mapping[str, Any],
                           rows: Sequence[Mapping[str, Any]],
                           out: Mapping[str, str | os.PathLike]) -> dict[str, float]:
    """Fig 6 (best case, identified vs true) and the match-bandwidth map, with captions.

    Parameters
    ----------
    datasets : sequence of xarray.Dataset
        ``identify`` outputs of every test, profile and method; Fig 6 draws those of the
        best case's test and profile.
    best : mapping
        ``identify.best``: ``test``, ``profile``, ``pairing`` and ``version`` of Fig 6.
    rows : sequence of mapping
        Rows of the ``identification_table`` CSV (``match_bandwidth_hz`` [Hz], ``pairing``,
        ``version``, ``test``, ``profile``, ``method``).
    out : mapping
        Output paths by name: ``fig6_png``, ``fig6_caption``, ``bandwidth_png`` and
        ``bandwidth_caption`` (the PDF goes beside each PNG).

    Returns
    -------
    dict
        Method -> match bandwidth [Hz] of the model drawn in Fig 6.
    """
    case = [ds for ds in datasets
            if ds.attrs["test"] == best["test"] and ds.attrs["profile"] == best["profile"]]
    bws = fig_bode_identified(case, best, out["fig6_png"])
    write_caption(out["fig6_caption"], "Identified vs true Bode magnitude", "paper Fig. 6",
                  f"{best['pairing']} on {best['test']} ({best['profile']}), "
                  f"{best['version']} data: true bench model (other loop closed as in the "
                  "test) and the PBSID, MOESP and N4SID models; lower panel: magnitude error "
                  "with the ±1 dB band.",
                  {f"{m.upper()} match bandwidth": f"{bw:.1f} Hz" for m, bw in bws.items()})
    fig_bandwidth(rows, out["bandwidth_png"])
    best_row = max(rows, key=lambda r: float(r["match_bandwidth_hz"]))
    write_caption(out["bandwidth_caption"],
                  "Match bandwidth across variants, methods, pairings and data versions",
                  "extension (paper section 3 and future work)",
                  "Highest frequency up to which the identified FRF stays within ±1 dB of the "
                  "true model, for every test variant, method, signal pairing and data "
                  "version.",
                  {"widest": f"{best_row['match_bandwidth_hz']} Hz ({best_row['pairing']}, "
                             f"{best_row['version']}, {best_row['test']} "
                             f"{best_row['profile']}, {best_row['method']})"})
    return bws
