"""Figure of the harmonic-removal trade-off: broadband damage against harmonic attenuation.

A removal is useful only if it takes the harmonics down *and* leaves the random
(broadband) response near the bench modes untouched. From the
:func:`gbpipe.harmonics.separation_metrics` output of each method, the left panel puts
one point per method and rpm bin at (worst level change over the mode bands, smallest
family attenuation), with the two targets drawn, so the methods that meet both sit in the
upper-left corner; the right panel shows the worst level change along the rpm sweep.
"""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np
import xarray as xr

from gbpipe.errors import DataError
from gbpipe.figures.captions import write_caption
from gbpipe.figures.style import new, save

__all__ = ["removal_tradeoff_figure"]

_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")
# Symlog below this level error [dB]: linear through 0 (a perfect method), log above, so
# 0.01 dB and 20 dB are both readable on one axis.
_LINTHRESH_DB = 0.01


def _bin_worst(ds: xr.Dataset, method: str) -> tuple[np.ndarray, np.ndarray]:
    """Worst mode-band ``|change_db|`` and smallest ``leftover_db``, per rpm bin [dB].

    ``elsewhere`` is left out of the change: the target is the level near the bench modes.
    """
    for var in ("change_db", "leftover_db"):
        if var not in ds:
            raise DataError(f"{method}: {var}",
                            "missing from the separation metrics; run "
                            "separation_metrics with harmonic_residual= so that "
                            "leftover_db is computed")
    modes = [str(b) for b in ds.band.values if str(b) != "elsewhere"]
    if not modes:
        raise DataError(f"{method}: band", "no mode band (only 'elsewhere'); give the "
                                           "structural modes to separation_metrics")
    change = np.abs(ds.change_db.sel(band=modes)).max("band", skipna=True)
    leftover = ds.leftover_db.min("family", skipna=True)
    return change.values.astype(float), leftover.values.astype(float)


def _fmt_db(value: float) -> str:
    """A level in dB for the caption; +inf is a perfect removal."""
    return "+inf dB (perfect)" if np.isposinf(value) else f"{value:.2f} dB"


def _best(values: Mapping[str, float], largest: bool) -> str:
    """Method with the best value (NaN never wins)."""
    finite = {m: v for m, v in values.items() if not np.isnan(v)}
    if not finite:
        return "none"
    pick = max if largest else min
    return pick(finite, key=finite.get)


def removal_tradeoff_figure(datasets: Mapping[str, xr.Dataset],
                            out: Mapping[str, str | os.PathLike],
                            tolerance_db: float = 1.0,
                            target_db: float = 60.0) -> dict[str, float]:
    """Level change near the modes against harmonic attenuation, per removal method.

    Parameters
    ----------
    datasets : mapping str -> xarray.Dataset
        Method name -> :func:`gbpipe.harmonics.separation_metrics` output of that method
        (with ``leftover_db``). (Speed is the benchmarks' business, not the figure's: a
        wall time in the caption would change from run to run.)
    out : mapping
        ``png`` and ``caption`` paths (the other formats go beside the PNG).
    tolerance_db : float
        Largest allowed level change in a mode band [dB] (the issue's "within 1 dB of the
        random-only signal").
    target_db : float
        Smallest wanted attenuation of every family [dB].

    Returns
    -------
    dict
        Per method: ``"<method> worst change dB"`` (largest mode-band ``|change_db|`` over
        the rpm bins [dB]) and ``"<method> worst attenuation dB"`` (smallest
        ``leftover_db`` over families and rpm bins [dB], +inf for a perfect removal).

    Raises
    ------
    DataError
        No dataset, or one without ``change_db``/``leftover_db`` or mode bands.
    """
    if not datasets:
        raise DataError("datasets", "no removal method given; pass at least one "
                                    "separation_metrics output")
    worst = {m: _bin_worst(ds, m) for m, ds in datasets.items()}
    finite_att = np.concatenate([a[np.isfinite(a)] for _, a in worst.values()])
    # +inf (perfect removal) cannot be drawn: clip it to the top, above every finite point.
    top = max([target_db, *finite_att]) + 10.0

    fig, (ax, ax_r) = new(1, 2, figsize=(10.0, 4.4))
    numbers: dict[str, float] = {}
    caption: dict[str, str] = {}
    meets_both: list[str] = []
    n_clipped = 0
    for k, (method, ds) in enumerate(datasets.items()):
        change, att = worst[method]
        style = dict(color=f"C{k % 10}", marker=_MARKERS[k % len(_MARKERS)])
        clipped = np.isposinf(att)
        n_clipped += int(clipped.sum())
        ax.scatter(change[~clipped], att[~clipped], s=22, alpha=0.8, **style,
                   label=method)
        # Clipped points drawn hollow at the top edge so they read as "off the scale".
        ax.scatter(change[clipped], np.full(clipped.sum(), top), s=40, facecolors="none",
                   edgecolors=style["color"], marker=style["marker"])
        ax_r.plot(ds.rpm.values, change, lw=1.2, ms=4, **style, label=method)
        numbers[f"{method} worst change dB"] = float(np.nanmax(change))
        numbers[f"{method} worst attenuation dB"] = float(np.nanmin(att))
        caption[f"{method}"] = (
            f"worst mode-band change {_fmt_db(numbers[f'{method} worst change dB'])}, "
            f"worst attenuation {_fmt_db(numbers[f'{method} worst attenuation dB'])}")
        # NaN (an empty bin) compares False: a bin that cannot be judged does not pass.
        if np.all(change <= tolerance_db) and np.all(att >= target_db):
            meets_both.append(method)

    ax.axvline(tolerance_db, color="k", ls="--", lw=0.9, label=f"tolerance {tolerance_db:g} dB")
    ax_r.axhline(tolerance_db, color="k", ls="--", lw=0.9, label=f"tolerance {tolerance_db:g} dB")
    ax.axhline(target_db, color="k", ls=":", lw=0.9, label=f"target {target_db:g} dB")
    ax.set_xscale("symlog", linthresh=_LINTHRESH_DB, linscale=0.5)
    all_change = np.concatenate([c for c, _ in worst.values()])
    x_max = max(20.0, 1.5 * float(np.nanmax(all_change, initial=0.0)))
    ax.set_xlim(0.0, x_max)
    ax.set_ylim(top=top + 4.0)
    ax.axhline(top, color="0.6", lw=0.6)
    ax.annotate("+inf (perfect removal), clipped", (0.01, top), xycoords=("axes fraction",
                "data"), xytext=(0, 2), textcoords="offset points", fontsize=7, color="0.4")
    ax.set_xlabel("worst |level change| in the mode bands [dB]")
    ax.set_ylabel("smallest family attenuation (leftover) [dB]")
    ax.set_title("Trade-off per rpm bin (upper left is best)")
    ax.legend(loc="best")  # away from the points
    ax_r.set_yscale("symlog", linthresh=_LINTHRESH_DB, linscale=0.5)
    ax_r.set_ylim(0.0, x_max)
    ax_r.set_xlabel("HSS speed (bin centre) [rev/min]")
    ax_r.set_ylabel("worst |level change| in the mode bands [dB]")
    ax_r.set_title("Broadband damage along the sweep")
    ax_r.legend(loc="upper right")
    save(fig, out["png"])

    changes = {m: numbers[f"{m} worst change dB"] for m in datasets}
    atts = {m: numbers[f"{m} worst attenuation dB"] for m in datasets}
    b_change, b_att = _best(changes, False), _best(atts, True)
    summary = {
        "least broadband damage": f"{b_change} ({_fmt_db(changes.get(b_change, np.nan))})",
        "most attenuation": f"{b_att} ({_fmt_db(atts.get(b_att, np.nan))})",
        f"meet both (<= {tolerance_db:g} dB change, >= {target_db:g} dB attenuation) in "
        "every rpm bin": ", ".join(meets_both) or "none",
    }
    write_caption(out["caption"], "Harmonic removal: broadband damage against attenuation",
                  "extension (choice of the harmonic-removal method)",
                  "Left: one point per method and rpm bin, the worst absolute level change "
                  "of the residual against the random-only signal over the mode bands "
                  "('elsewhere' excluded) against the smallest family attenuation on the "
                  f"harmonic part; dashed: tolerance {tolerance_db:g} dB, dotted: target "
                  f"{target_db:g} dB. {n_clipped} point(s) with +inf "
                  "attenuation (perfect removal) are clipped to the top of the axis (hollow "
                  "markers). Right: worst level change per rpm bin along the sweep.",
                  {**summary, **caption})
    return numbers
