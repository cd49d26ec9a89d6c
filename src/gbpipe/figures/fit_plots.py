"""The physical fit's figure: the identified FRF with its 95 % bounds, the model at the
prior and the fitted model, per fitted pairing (or, for a modal table, each mode's
frequency error before and after), the goodness of fit, and the parameter table.

Reads one ``fit`` stage dataset (:func:`gbpipe.fit.fit_dataset`). See docs/fit.md.
"""

from __future__ import annotations

import os

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from gbpipe.figures.captions import write_caption
from gbpipe.figures.style import save

__all__ = ["fig_fit", "fit_numbers"]


def fit_numbers(ds: xr.Dataset) -> dict[str, str]:
    """Caption numbers: each parameter's prior, estimate, interval and status; the delay."""
    out = {}
    for i, p in enumerate(ds.parameter.values):
        unit = str(ds.parameter_units.values[i])
        lo, hi = float(ds.interval_lower[i]), float(ds.interval_upper[i])
        iv = f", 95 % [{lo:.4g}, {hi:.4g}]" if np.isfinite(lo) else ""
        out[str(p)] = (f"{float(ds.prior[i]):.4g} -> {float(ds.estimate[i]):.4g} {unit}{iv} "
                       f"({ds.status.values[i]})")
    if "delay" in ds and np.isfinite(float(ds.delay_lower)):
        out["delay"] = (f"{float(ds.delay) * 1e3:.4f} ms, 95 % [{float(ds.delay_lower) * 1e3:.4f}, "
                        f"{float(ds.delay_upper) * 1e3:.4f}] ms")
    out["intervals"] = str(ds.attrs["interval_method"])
    out["cost"] = f"{float(ds.cost_prior):.3g} at the prior -> {float(ds.cost):.3g}"
    out["cannot separate"] = ds.attrs["cannot_separate"]
    out["goodness"] = f"{ds.attrs['fit_status']}: {ds.attrs['fit_reason']}"
    if "mode" in ds.dims:
        fd = ds.mode_frequency_data.values
        for key in ("prior", "fitted"):
            err = 100 * (ds[f"mode_frequency_{key}"].values / fd - 1)
            out[f"mode frequency error, {key}"] = ", ".join(f"{e:+.2f} %" for e in err)
    return out


def _modes_panel(ax: plt.Axes, ds: xr.Dataset) -> None:
    """Mode by mode: the frequency error [%] of the prior and the fitted model against
    the data, with the data's 95 % band."""
    fd = ds.mode_frequency_data.values
    band = 100 * 1.96 * ds.mode_frequency_sd.values / fd
    ax.errorbar(fd, np.zeros_like(fd), yerr=band, fmt="o", color="C0", ms=3,
                label="data, 95 %")
    ax.semilogx(fd, 100 * (ds.mode_frequency_prior.values / fd - 1), "C3x", label="prior")
    ax.semilogx(fd, 100 * (ds.mode_frequency_fitted.values / fd - 1), "k+", label="fitted")
    ax.set_xlabel("identified frequency [Hz]")
    ax.set_ylabel("model − data [%]")
    ax.set_title("modal table: frequency error per mode")
    ax.legend(loc="best", fontsize=6)


def fig_fit(ds: xr.Dataset, stem: str | os.PathLike, caption: str | os.PathLike,
            record: str) -> dict[str, str]:
    """Draw the fit of one record and write its caption; return the caption numbers.

    Parameters
    ----------
    ds : xarray.Dataset
        A ``fit`` stage output.
    stem : path-like
        Target ``<stem>.png``, and the other formats beside it (a suffix is dropped).
    caption : path-like
        The ``.rst`` caption.
    record : str
        ``{test}_{profile}`` (for the title).
    """
    frf = "frf_prior_real" in ds
    pairs = [(k, o, i) for k in range(ds.sizes["pairing"]) for o in range(ds.sizes["output"])
             for i in range(ds.sizes["input"])
             if np.isfinite(ds.frf_prior_real.values[k, 0, o, i])] if frf else []
    n_panels = len(pairs) + ("mode" in ds.dims)
    ncols = min(n_panels, 3)
    nrows = -(-n_panels // ncols)
    mosaic = [[f"p{r * ncols + c}" for c in range(ncols)] for r in range(nrows)]
    mosaic.append(["table"] * ncols)
    # at least 8 in wide: the parameter table and the two-line title need it
    fig = plt.figure(figsize=(max(3.3 * ncols + 0.6, 8.0), 2.5 * nrows + 1.0 + 0.22 * ds.sizes[
        "parameter"]), layout="constrained")
    ax_of = fig.subplot_mosaic(mosaic, height_ratios=[1.0] * nrows + [
        0.3 + 0.1 * ds.sizes["parameter"]])
    f = ds.frequency.values if frf else None

    def db(name: str, k: int, o: int, i: int) -> np.ndarray:
        g = ds[f"{name}_real"].values[k, :, o, i] + 1j * ds[f"{name}_imag"].values[k, :, o, i]
        return 20 * np.log10(np.abs(g))

    welch = ds.attrs.get("data") == "nonparametric"
    source = "Welch estimate" if welch else "identified"
    for n, (k, o, i) in enumerate(pairs):
        ax = ax_of[f"p{n}"]
        used = ds.fitted.values[k].astype(bool)
        ax.fill_between(f, ds.frf_data_lower_db.values[k, :, o, i],
                        ds.frf_data_upper_db.values[k, :, o, i], color="C0", alpha=0.25,
                        lw=0, label=f"{source}, 95 %")
        data = db("frf_data", k, o, i)
        ax.semilogx(f, np.where(used, data, np.nan), "C0", lw=1.6, label=f"{source} (fitted)")
        ax.semilogx(f, np.where(used, np.nan, data), "C0", lw=0.8, ls=":",
                    label=f"{source} (not fitted)")
        ax.semilogx(f, db("frf_prior", k, o, i), "C3", lw=0.9, ls="--", label="prior model")
        ax.semilogx(f, db("frf_fitted", k, o, i), "k", lw=0.9, label="fitted model")
        suffix = f" [{o},{i}]" if ds.sizes["output"] * ds.sizes["input"] > 1 else ""
        ax.set_title(f"{ds.pairing.values[k]}{suffix}")
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel(f"|G| [dB re 1 {ds.frf_unit.values[k]}]")
    if "mode" in ds.dims:
        _modes_panel(ax_of[f"p{len(pairs)}"], ds)
    for n in range(n_panels, nrows * ncols):
        ax_of[f"p{n}"].set_axis_off()
    ax_of["p0"].legend(loc="best", fontsize=6)
    ax_of["table"].set_axis_off()
    rows = []
    for j, p in enumerate(ds.parameter.values):
        lo, hi = float(ds.interval_lower[j]), float(ds.interval_upper[j])
        rows.append([str(p), str(ds.parameter_units.values[j]), f"{float(ds.prior[j]):.4g}",
                     f"{float(ds.estimate[j]):.4g}",
                     f"[{lo:.4g}, {hi:.4g}]" if np.isfinite(lo) else "–",
                     str(ds.status.values[j])])
    if "delay" in ds and np.isfinite(float(ds.delay_lower)):
        rows.append(["delay", "ms", "0", f"{float(ds.delay) * 1e3:.4g}",
                     f"[{float(ds.delay_lower) * 1e3:.4g}, {float(ds.delay_upper) * 1e3:.4g}]",
                     "fitted"])
    table = ax_of["table"].table(cellText=rows, colLabels=[
        "parameter", "unit", "prior", "fitted",
        f"95 % interval ({ds.attrs['interval_method']})", "status"],
                              loc="center", cellLoc="left",
                              # key paths and the interval's method need the room
                              colWidths=[0.30, 0.10, 0.10, 0.10, 0.28, 0.12])
    table.auto_set_font_size(False)
    table.set_fontsize(7)
    what = (f"a modal table ({ds.attrs['system']} modes)" if not frf
            else f"the record's Welch FRFs ({ds.attrs['version']} data)" if welch
            else f"the identified FRFs ({ds.attrs['version']} data)")
    fig.suptitle(f"Physical fit to {what}, {record}\ngoodness of fit: "
                 f"{ds.attrs['fit_status']} ({ds.attrs['fit_reason']})", fontsize=9)
    save(fig, stem)
    numbers = fit_numbers(ds)
    write_caption(caption, f"Physical fit, {record}", "extension (the paper's future work)",
                  "Identified FRF, or with fit.data: nonparametric the record's Welch "
                  "estimate (blue, 95 % bounds shaded; dotted where not fitted: outside "
                  "the band, where the design step predicts the pairing unidentifiable, or "
                  "where the estimate is not coherent; a Welch estimate is compared with "
                  "the model seen through its window, the curves show the model itself), "
                  "the bench model at the prior (red, dashed) and the fitted model (black), "
                  "and the fitted parameters with their 95 % intervals. An unidentifiable "
                  "parameter keeps its prior and gets no interval; a fit that fails the "
                  "chi-square test against the data's bounds is poor and none of its "
                  "parameters is identified. For a modal table: each mode's frequency "
                  "error of the prior (red) and the fitted model (black) against the data "
                  "(blue, 95 % band).", numbers)
    return numbers
