"""Figure of the harmonic-removal trade-off: broadband damage against harmonic attenuation.

A removal is useful only if it takes the harmonics down *and* leaves the random
(broadband) response near the bench modes untouched. From the
:func:`gbpipe.harmonics.separation_metrics` output of each method, the left panel puts
one point per method and rpm bin at (worst level change over the mode bands, smallest
family attenuation), with the two targets drawn, so the methods that meet both sit in the
upper-left corner; the right panel shows the worst level change along the rpm sweep.

:func:`removal_crossing_figure` zooms on the worst order/mode crossing: the mode band's
power along rpm in the record, its random-only twin and each method's residual.
"""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np
import xarray as xr

from gbpipe.errors import DataError
from gbpipe.figures.captions import write_caption
from gbpipe.figures.style import new, save
from gbpipe.harmonics.separation import band_power_vs_rpm

__all__ = ["removal_tradeoff_figure", "removal_crossing_figure", "worst_crossing"]

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


def worst_crossing(datasets: Mapping[str, xr.Dataset]) -> tuple[int, int, bool]:
    """The mode band and rpm bin of the worst crossing: among the bins where an order
    lies within a mode's half-power band (``crossing_order``), the one with the largest
    ``|change_db|`` of any method; without any crossing, the worst mode-band bin.

    Returns
    -------
    band, rpm : int
        Indices into the datasets' ``band`` and ``rpm``.
    crossed : bool
        Whether that bin is a crossing.
    """
    first = next(iter(datasets.values()))
    # fmax: NaN only where every method's change is NaN (no all-NaN warning)
    change = np.fmax.reduce(np.stack([np.abs(ds.change_db.transpose("band", "rpm").values)
                                      for ds in datasets.values()]), axis=0)
    change[first.band.values == "elsewhere"] = np.nan
    crossed = np.isfinite(first.crossing_order.transpose("family", "band", "rpm").values
                          ).any(axis=0)
    pick = np.where(crossed, change, np.nan)
    # no crossing, or none with a finite change (e.g. bins without waterfall frames): the
    # worst mode-band bin
    crossed_any = bool(np.isfinite(pick).any())
    if not crossed_any:
        pick = change
    if not np.isfinite(pick).any():
        raise DataError("change_db", "no mode-band bin has a finite level change: the "
                        "sweep gives no waterfall frame in any rpm bin; lengthen the sweep")
    b, i = np.unravel_index(np.nanargmax(pick), pick.shape)
    return int(b), int(i), crossed_any


def removal_crossing_figure(datasets: Mapping[str, xr.Dataset], record: np.ndarray,
                            random_only: np.ndarray, fs: float, pulse_times: np.ndarray,
                            out: Mapping[str, str | os.PathLike], *,
                            pulses_per_rev: int = 1, resolution: float = 0.5,
                            fine_bins: int = 15, units: str = "N·m",
                            tolerance_db: float = 1.0) -> dict[str, float]:
    """Zoom on the worst crossing: the mode band's power along rpm in the record, in the
    random-only twin and in each method's residual.

    Parameters
    ----------
    datasets : mapping str -> xarray.Dataset
        Method -> :func:`gbpipe.harmonics.compare_method` output (``residual``,
        ``change_db``, ``crossing_order``, ``crossing_mode``).
    record, random_only : numpy.ndarray
        The sweep's signal and its random-only twin (unit ``units``).
    fs : float
        Sample rate [Hz].
    pulse_times : numpy.ndarray
        HSS tachometer pulse times of the sweep [s].
    out : mapping
        ``png`` and ``caption`` paths (the other formats go beside the PNG).
    pulses_per_rev : int
        Tachometer pulses per HSS revolution.
    resolution : float
        Resolution of the waterfalls behind the band powers [Hz].
    fine_bins : int
        Most rpm bins over the zoom (the worst metric bin and its neighbours); fewer
        where the sweep crosses the zoom in fewer than two waterfall frames per bin.
    units : str
        Unit of the signals, as written in labels.
    tolerance_db : float
        The allowed level change [dB], drawn.

    Returns
    -------
    dict
        ``"<method> zoom worst change dB"`` per method (largest ``|change|`` of the fine
        bins against the random-only twin [dB]), ``"mode Hz"``, ``"order"`` (NaN without a
        crossing), ``"rpm lower"``/``"rpm upper"`` of the zoom [rev/min].
    """
    if not datasets:
        raise DataError("datasets", "no removal method given")
    b, i, crossed = worst_crossing(datasets)
    first = next(iter(datasets.values()))
    limits = (float(first.band_lower[b]), float(first.band_upper[b]))
    lo_i, hi_i = max(i - 1, 0), min(i + 1, first.sizes["rpm"] - 1)
    span = (float(first.rpm_lower[lo_i]), float(first.rpm_upper[hi_i]))
    # at most one bin per two waterfall frames (hop 1 / (2 resolution) s) in the zoom: a
    # fast sweep crosses it in a few frames
    p = np.asarray(pulse_times, dtype=float)
    rev_rpm = 60.0 / (np.diff(p) * pulses_per_rev)
    inside = (rev_rpm >= span[0]) & (rev_rpm <= span[1])
    n_frames = float(np.sum(np.diff(p)[inside])) * 2.0 * resolution
    edges = np.linspace(*span, int(np.clip(n_frames // 2, 3, fine_bins)) + 1)
    names = list(datasets)
    power = band_power_vs_rpm([record, random_only,
                               *(datasets[m].residual.values for m in names)], fs,
                              pulse_times, limits, edges, resolution=resolution,
                              pulses_per_rev=pulses_per_rev)
    centre = 0.5 * (edges[:-1] + edges[1:])
    with np.errstate(divide="ignore", invalid="ignore"):
        level = 10 * np.log10(power)
    orders = first.crossing_order.transpose("family", "band", "rpm").values[:, b, i]
    mode_hz = first.crossing_mode.transpose("family", "band", "rpm").values[:, b, i]
    known = np.isfinite(orders)
    order = float(orders[known][0]) if known.any() else np.nan
    mode = float(mode_hz[known][0]) if known.any() else float(np.mean(limits))

    fig, (ax, ax_r) = new(1, 2, figsize=(10.0, 4.4))
    ax.plot(centre, level[0], color="0.6", lw=2.5, label="record")
    ax.plot(centre, level[1], color="k", ls="--", lw=1.5, label="random-only")
    ax_r.axhspan(-tolerance_db, tolerance_db, color="0.9", label=f"±{tolerance_db:g} dB")
    numbers: dict[str, float] = {"mode Hz": mode, "order": order,
                                 "rpm lower": float(edges[0]), "rpm upper": float(edges[-1])}
    caption: dict[str, str] = {}
    for k, m in enumerate(names):
        style = dict(color=f"C{k % 10}", marker=_MARKERS[k % len(_MARKERS)], ms=4)
        ax.plot(centre, level[2 + k], lw=1.2, **style, label=m)
        change = level[2 + k] - level[1]
        ax_r.plot(centre, change, lw=1.2, **style, label=m)
        numbers[f"{m} zoom worst change dB"] = float(np.nanmax(np.abs(change)))
        caption[m] = f"worst change in the zoom {numbers[f'{m} zoom worst change dB']:.2f} dB"
    if known.any():  # the speed where the order's frequency is the mode's
        for a in (ax, ax_r):
            a.axvline(60.0 * mode / order, color="0.3", lw=0.8, ls=":")
    ax.set_xlabel("HSS speed [rev/min]")
    ax.set_ylabel(f"power in {limits[0]:.1f}–{limits[1]:.1f} Hz [dB re ({units})²]")
    ax.set_title("Mode band along the sweep")
    ax.legend(loc="best", fontsize=7)
    ax_r.set_xlabel("HSS speed [rev/min]")
    ax_r.set_ylabel("level change against random-only [dB]")
    ax_r.set_title("Residual against the random-only twin")
    ax_r.legend(loc="best", fontsize=7)
    save(fig, out["png"])
    where = (f"order {order:g} through the {mode:.1f} Hz mode at "
             f"{60.0 * mode / order:.0f} rev/min" if crossed else
             "no order lies within a mode's half-power band on this sweep: the worst "
             "mode-band bin instead")
    write_caption(out["caption"], "Harmonic removal at the worst order/mode crossing",
                  "extension (harmonic removal at crossings)",
                  f"Left: power in the {limits[0]:.1f}–{limits[1]:.1f} Hz mode band along "
                  "the sweep, in the record, in its random-only twin (same seeds, no "
                  "angle-locked excitation) and in each method's residual, over the worst "
                  "crossing's rpm bin and its neighbours; right: each residual's level "
                  f"change against the random-only twin, ±{tolerance_db:g} dB shaded. "
                  "Dotted: the speed where the order's frequency equals the mode's.",
                  {"zoom": f"{edges[0]:.0f}–{edges[-1]:.0f} rev/min, {where}", **caption})
    return numbers
