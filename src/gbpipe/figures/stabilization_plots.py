"""Stabilization diagram of one bench record and pairing: the modes the data choose.

One panel per diagram method (the subspace method, LSCF): the poles of every model order
(order on the left axis, frequency across), the stable ones marked, the clusters' poles
coloured by their kind (mode, harmonic, spurious in grey), each mode with its frequency
spread over the orders, the order lines' bands shaded and named by their order, the zoomed
bands' edges dotted, each
cluster labelled with its frequency; the nonparametric FRF's mode indicator behind them
on the right axis (:func:`gbpipe.identify.record_modes`, docs/modal.md).
"""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np
import xarray as xr

from gbpipe.figures.captions import write_caption
from gbpipe.figures.style import new, save

__all__ = ["stabilization_figure"]

_KIND_COLOR = {"mode": "C0", "harmonic": "C3", "spurious": "0.55"}


def stabilization_figure(ds: xr.Dataset, pairing: str, record: str,
                         out: Mapping[str, str | os.PathLike]) -> dict[str, str]:
    """Stabilization diagrams of one pairing of a ``modes_measured`` output.

    Parameters
    ----------
    ds : xarray.Dataset
        :func:`gbpipe.identify.record_modes` of the record.
    pairing : str
        The pairing drawn.
    record : str
        Record name (title).
    out : mapping
        ``png`` and ``caption`` paths (the other formats go beside the PNG).

    Returns
    -------
    dict
        The caption's key numbers: per method, the model order and the clusters
        (frequency [Hz], damping [%], kind).
    """
    d = ds.sel(pairing=pairing)
    methods = [str(m) for m in ds.method.values]
    fig, axes = new(1, len(methods), figsize=(6.0 * len(methods), 4.6), squeeze=False)
    f = ds.frequency.values
    numbers: dict[str, str] = {}
    for ax, method in zip(axes[0], methods, strict=True):
        m = d.sel({"method": method})
        top = np.nanmax(m.order.values)
        for k, lo, hi in zip(ds.harmonic_order.values, ds.harmonic_low.values,
                             ds.harmonic_high.values, strict=True):
            ax.axvspan(lo, hi, color="0.85", lw=0, zorder=0)
            ax.text(0.5 * (lo + hi), 0.02 * top, f"{k:.4g}x", rotation=90, fontsize=5,
                    ha="center", va="bottom", color="0.35")
        for edge in ds.zoom_edge_frequency.values:
            # below each edge the poles come from the data decimated further (zoom)
            ax.axvline(edge, color="0.4", ls=":", lw=0.8, zorder=0)
        order = m.order.values[:, None] * np.ones(m.pole_frequency.shape[-1])
        pf, stable = m.pole_frequency.values, m.pole_stable.values > 0
        cluster = m.pole_cluster.values
        ax.plot(pf[~stable], order[~stable], ".", color="0.6", ms=2, label="pole")
        ax.plot(pf[stable & (cluster < 0)], order[stable & (cluster < 0)], "+", color="k",
                ms=4, label="stable pole")
        kinds = m.mode_kind.values
        for kind, color in _KIND_COLOR.items():
            sel = stable & (cluster >= 0)
            sel &= np.isin(cluster, np.flatnonzero(kinds == kind))
            ax.plot(pf[sel], order[sel], "o", color=color, ms=3, mfc="none",
                    label=f"cluster: {kind}")
        for c in np.flatnonzero(np.isfinite(m.mode_frequency.values)):
            fc = float(m.mode_frequency.values[c])
            if kinds[c] == "mode":  # the spread of a mode over the orders that hold it
                ax.errorbar(fc, top * 1.03, xerr=float(m.mode_frequency_spread.values[c]),
                            fmt="v", color="C0", ms=3, capsize=2, lw=0.8)
            ax.annotate(f"{fc:.1f}", (fc, top), xytext=(0, 4), textcoords="offset points",
                        rotation=90, fontsize=6, ha="center", va="bottom",
                        color=_KIND_COLOR.get(str(kinds[c]), "k"))
        twin = ax.twinx()
        twin.plot(f, d.frf_indicator.values, color="C2", lw=0.8, alpha=0.8)
        twin.set_ylabel("FRF indicator [dB]", color="C2")
        twin.grid(False)
        status = str(m.status.values)
        ax.set_title(f"{record} {pairing}: {method.upper()} (model order "
                     f"{int(m.model_order)})" + ("" if status == "ok" else f"\n{status}"[:90]),
                     fontsize=8)
        ax.set_xlim(f[0], f[-1])
        ax.set_ylim(0, top * 1.15)
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel("model order [-]")
        ax.legend(fontsize=6, loc="lower right")
        numbers[f"{method} model order"] = str(int(m.model_order))
        numbers[f"{method} clusters"] = ", ".join(
            f"{float(m.mode_frequency.values[c]):.1f} Hz "
            f"({100 * float(m.mode_damping.values[c]):.1f} %, {kinds[c]})"
            for c in np.flatnonzero(np.isfinite(m.mode_frequency.values))) or "none"
    save(fig, out["png"])
    write_caption(out["caption"], f"Stabilization diagrams of record {record}, {pairing}",
                  "extension (modes chosen by the data)",
                  "Poles of every model order (grey dots), stable poles (+), clusters of "
                  "stable poles (circles: blue a mode, with its frequency spread over the "
                  "orders at the top; red an order line; grey a noise pole), the order "
                  "lines' bands named by their order over the record's speed range widened "
                  "by the resolution (shaded; the speed: "
                  f"{ds.attrs.get('speed_source', 'the tacho')}), the edges below which "
                  "the poles come from the data decimated further (dotted, zoom; each "
                  "diagram's clusters below its band keep theirs), and the "
                  "nonparametric FRF's mode indicator (green, right axis).",
                  numbers)
    return numbers
