"""The virtual torque sensor's figure: each held-out sensor's measurement against its
estimate and 95 % band (a window of the steady part), every estimated target's band, and
the load spectra of every measured and estimated torque (rainflow exceedance, time at
level, damage-equivalent loads).

Reads one ``virtual`` stage dataset (:func:`gbpipe.virtual.virtual_record`), best opened
lazily: of the series on time only the window shown is read (an hour at 5 kHz holds
3.9 GB of estimates and bands). See docs/virtual.md.
"""

from __future__ import annotations

import os

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from gbpipe.figures.captions import write_caption
from gbpipe.figures.style import save
from gbpipe.virtual import Z95

__all__ = ["fig_virtual"]

#: Length [s] of the time window shown (the middle of the steady part).
WINDOW_S = 0.5


def _window(ds: xr.Dataset) -> slice:
    steady = np.flatnonzero(ds.steady.values)
    t = ds.time.values
    mid = steady[len(steady) // 2] if steady.size else len(t) // 2
    n = max(int(WINDOW_S / float(np.median(np.diff(t)))), 2)
    return slice(max(mid - n // 2, 0), mid + n // 2)


def fig_virtual(ds: xr.Dataset, stem: str | os.PathLike, caption: str | os.PathLike,
                record: str) -> dict[str, str]:
    """Draw the virtual sensors of one record and write its caption; return the numbers.

    Parameters
    ----------
    ds : xarray.Dataset
        A ``virtual`` stage output.
    stem : path-like
        Target ``<stem>.png`` (other formats beside it).
    caption : path-like
        The ``.rst`` caption.
    record : str
        Record name (title).
    """
    holdout = [str(h) for h in ds.holdout.values] if "holdout" in ds.dims else []
    shown = holdout or [str(ds.target.values[0])]
    # per held-out sensor: the signals (two thirds) and their difference with the band
    # (the band is too narrow to see against the signal's own swing)
    mosaic = [[f"t{r}", f"t{r}", f"e{r}"] for r in range(len(shown))] + [
        ["rainflow", "ldd", "del"]]
    fig = plt.figure(figsize=(10.0, 2.4 * (len(shown) + 1)), layout="constrained")
    ax_of = fig.subplot_mosaic(mosaic)
    w = _window(ds)
    t = ds.time.values[w]
    numbers = {}
    for r, name in enumerate(shown):
        ax = ax_of[f"t{r}"]
        j = [str(x) for x in ds.target.values].index(name)
        unit = str(ds.target_units.values[j])
        ax.fill_between(t, ds.lower[w, j].values, ds.upper[w, j].values, color="C0",
                        alpha=0.3, lw=0, label="estimate, 95 % band")
        ax.plot(t, ds.estimate[w, j].values, "C0", lw=1.0, label="estimate")
        if name in holdout:
            i = holdout.index(name)
            ax.plot(t, ds.holdout_measured[w, i].values, "k", lw=0.6,
                    label="held-out measurement")
            fit = float(ds.holdout_fit_percent.values[i])
            cov = float(ds.holdout_coverage_95.values[i])
            rms = float(ds.holdout_rms_error.values[i])
            ax.set_title(f"{name}: fit {fit:.1f} %, RMS error {rms:.3g} {unit}, "
                         f"{100 * cov:.1f} % inside the 95 % band (+ sensor noise)",
                         fontsize=8)
            numbers[f"{name} fit"] = f"{fit:.1f} %"
            numbers[f"{name} coverage"] = f"{100 * cov:.1f} %"
            err = ax_of[f"e{r}"]
            half = Z95 * np.hypot(float(ds.estimate_sd.values[j]),
                                   float(ds.holdout_noise_sd.values[i]))
            err.fill_between(t, -half, half, color="C0", alpha=0.3, lw=0,
                             label="95 % band + sensor noise")
            err.plot(t, ds.holdout_measured[w, i].values - ds.estimate[w, j].values, "k",
                     lw=0.6, label="measurement − estimate")
            err.set(xlabel="time [s]", ylabel=f"[{unit}]")
            err.legend(loc="upper right", fontsize=6)
        else:
            ax_of[f"e{r}"].set_axis_off()
        ax.set_xlabel("time [s]")
        ax.set_ylabel(f"{name} [{unit}]")
        ax.legend(loc="upper right", fontsize=6)
    sig = [str(s) for s in ds.signal.values]
    for k, s in enumerate(sig):
        style = "-" if str(ds.signal_source.values[k]) == "measured" else "--"
        counts = ds.cycle_count.values[k]
        exceed = np.cumsum(counts[::-1])[::-1]
        ax_of["rainflow"].semilogy(ds.cycle_range.values[k], np.maximum(exceed, 0.5), style, lw=0.9,
                            label=s)
        ax_of["ldd"].plot(ds.load_level.values[k], ds.time_at_level.values[k], style, lw=0.9)
        ax_of["del"].plot(ds.sn_slope.values, ds["del"].values[k], style, marker="o", ms=3,
                        lw=0.9)
    ax_of["rainflow"].set(xlabel="rainflow range [N m]", ylabel="cycles exceeding [-]")
    ax_of["ldd"].set(xlabel="torque level [N m]", ylabel="time at level [s]")
    f_eq = ds.attrs["equivalent_frequency_hz"]
    ax_of["del"].set(xlabel="S-N slope m [-]", ylabel=f"DEL at {f_eq:g} Hz [N m]")
    ax_of["rainflow"].legend(fontsize=5, loc="upper right")
    fig.suptitle(f"Virtual torque sensors, {record} (solid: measured, dashed: estimated)",
                 fontsize=9)
    save(fig, stem)
    write_caption(caption, f"Virtual torque sensors, {record}", "extension (issue 46)",
                  "Top: each held-out sensor's measurement (black) against its estimate "
                  "from the other signals (blue) and the 95 % band (shaded), a window of the "
                  "steady part, and beside it their difference against the band widened by "
                  "the sensor's own noise (the title's coverage counts the samples inside "
                  "it). Bottom: load spectra of every "
                  "measured (solid) and estimated (dashed) torque: rainflow cycles exceeding "
                  "each range, time at level, and the damage-equivalent load range per S-N "
                  "slope (N_eq = f_eq T).", numbers)
    return numbers
