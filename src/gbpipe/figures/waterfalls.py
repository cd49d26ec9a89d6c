"""Figures 11–17: power and order spectra vs rpm, raw and after TSA; mode-band check.

:func:`harmonics_figures` draws them all, with their report captions, from the outputs of
the ``spectra`` and ``tsa`` stages (docs/architecture.md, "Stage graph").
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.figures.captions import write_caption
from gbpipe.figures.style import db, new, save
from gbpipe.kinematics import order_of

__all__ = ["fig_power_waterfall", "fig_order_waterfall", "fig_mode_band", "harmonics_figures",
           "CYCLE_DESCRIPTIONS"]

#: How the captions name the cycles of the paper's variants (others: "<name> cycles").
CYCLE_DESCRIPTIONS = {"hss": "HSS cycles", "carrier2": "planet-carrier-2 revolutions",
                      "mesh2": "stage-2 gear-mesh periods"}


def _mesh(ax, x, y, z, vmax, dyn, label):
    m = ax.pcolormesh(x, y, z, shading="nearest", cmap="viridis", vmin=vmax - dyn, vmax=vmax,
                      rasterized=True)
    return m


def _waterfall(x: xr.DataArray, y: xr.DataArray, power: xr.DataArray, stem, title: str,
               xlabel: str, vmax: float | None, dynamic_range: float, decorate) -> float:
    """Power in dB over (x, rpm) with a colour bar; ``decorate(ax)`` adds the marks.
    Returns the top of the colour scale [dB] (to share it between figures)."""
    fig, ax = new(figsize=(7.0, 4.6))
    z = db(power.values, power=True)
    vmax = float(np.nanmax(z)) if vmax is None else vmax
    m = _mesh(ax, x, y, z, vmax, dynamic_range, "")
    decorate(ax)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("HSS speed [rpm]")
    ax.set_title(title)
    fig.colorbar(m, ax=ax, label=f"power [dB re 1 {power.attrs['units']}]")
    save(fig, stem)
    return vmax


def fig_power_waterfall(ds: xr.Dataset, stem, title: str, *, vmax: float | None = None,
                        dynamic_range: float = 70.0, modes=()) -> float:
    """Power spectrum vs rpm (frequency on x, rpm on y), in dB re 1 (N·m)²."""
    def decorate(ax):
        for f in modes:
            ax.axvline(f, color="w", lw=0.6, ls="--")

    return _waterfall(ds.frequency, ds.rpm, ds.power, stem, title, "frequency [Hz]", vmax,
                      dynamic_range, decorate)


def fig_order_waterfall(ds: xr.Dataset, stem, title: str, *, vmax: float | None = None,
                        dynamic_range: float = 70.0, marks: Mapping[str, float] | None = None
                        ) -> float:
    """Order spectrum vs rpm (order on x, rpm on y), in dB."""
    def decorate(ax):
        for label, o in (marks or {}).items():
            ax.axvline(o, color="w", lw=0.5, ls=":")
            ax.annotate(label, (o, 1.0), xycoords=("data", "axes fraction"), rotation=90,
                        va="top", ha="right", fontsize=7, color="w")

    return _waterfall(ds.order, ds.order_rpm, ds.order_power, stem, title,
                      "order of the HSS [-]", vmax, dynamic_range, decorate)


def fig_mode_band(variants: Mapping[str, xr.Dataset], stem) -> None:
    """Change of the power in the band around each structural mode vs rpm, per variant."""
    first = next(iter(variants.values()))
    modes = first.mode_frequency.values
    fig, axes = new(len(modes), 1, figsize=(7.0, 1.9 * len(modes) + 0.6), sharex=True,
                    squeeze=False)
    for ax, (k, f) in zip(axes[:, 0], enumerate(modes), strict=True):
        for i, (name, ds) in enumerate(variants.items()):
            ch = ds.mode_change_vs_rpm.isel(mode=k)
            ax.plot(ds.metric_rpm, ch, marker="o", ms=3, color=f"C{i}",
                    label=f"{name} ({float(ds.mode_change.isel(mode=k)):+.2f} dB)")
            cross = ds.crossing.isel(mode=k).any("family")
            ax.plot(ds.metric_rpm[cross.values], ch[cross.values], "x", color=f"C{i}", ms=7)
        ax.axhspan(-1, 1, color="0.85", zorder=0)
        ax.set_ylabel("Δ band [dB]")
        ax.set_title(f"mode {f:.1f} Hz ± {float(first.band_half_width.isel(mode=k)):.0f} Hz",
                     fontsize=8)
        ax.legend(fontsize=6, ncol=2, loc="lower left")
    axes[-1, 0].set_xlabel("HSS speed [rpm]")
    fig.suptitle("Resonance bands after TSA (x: a removed family crosses the band; "
                 "grey: ±1 dB)", fontsize=9)
    save(fig, stem)


def _mode_numbers(ds: xr.Dataset) -> dict[str, str]:
    """Caption lines: band change of each mode, worst bin without and bins with a crossing."""
    numbers = {}
    for m, f in enumerate(ds.mode_frequency.values):
        ch = ds.mode_change_vs_rpm.isel(mode=m).values
        cross = ds.crossing.isel(mode=m).any("family").values.astype(bool)
        free = np.where(cross, np.nan, np.abs(ch))
        text = f"{float(ds.mode_change.isel(mode=m)):+.2f} dB overall (bins without a crossing)"
        if np.isfinite(free).any():
            w = int(np.nanargmax(free))
            text += f"; worst such bin {float(ds.metric_rpm[w]):.0f} rpm: {ch[w]:+.2f} dB"
        if cross.any():
            text += (f"; {int(cross.sum())} bin(s) where a removed family crosses the band: "
                     f"{', '.join(f'{c:+.1f}' for c in ch[cross])} dB (the harmonic itself)")
        numbers[f"mode {f:.1f} Hz band change"] = text
    return numbers


def harmonics_figures(raw: xr.Dataset, variants: Mapping[str, xr.Dataset],
                      out: Mapping[str, str | os.PathLike], *, n_cycles: int,
                      stages: Sequence[Mapping[str, Any]]) -> None:
    """Figures 11-17 and the resonance-band check, each with its report caption.

    Parameters
    ----------
    raw : xarray.Dataset
        Waterfalls of the raw sweep (``spectra`` stage).
    variants : mapping str -> xarray.Dataset
        TSA variant outputs (``tsa`` stage), in config order; figures 12-17 show the
        first three (the paper's: hss, carrier2, mesh2).
    out : mapping
        Output paths by name: ``fig<n>_png`` and ``fig<n>_caption`` for n = 11..17,
        ``mode_band_png`` and ``mode_band_caption`` (the other formats go beside each PNG).
    n_cycles : int
        Cycles per average (``tsa.n_cycles``), for the captions.
    stages : sequence of mapping
        ``cfg["gearbox"]["stages"]``: the mesh orders marked on the order spectra.

    Raises
    ------
    ValueError
        Fewer than three variants.
    """
    if len(variants) < 3:
        raise ValueError("figures 12-17 need three TSA variants in config tsa.variants")
    modes = next(iter(variants.values())).mode_frequency.values
    vmax = fig_power_waterfall(raw, out["fig11_png"], "Fig. 11 — torque power spectrum vs "
                               "rpm, raw sweep (GB1)", modes=modes)
    f11 = raw.power.sum("frequency")
    write_caption(out["fig11_caption"], "Raw sweep waterfall", "paper Fig. 11",
                  "Power spectrum of the GB1 torque meter vs HSS speed: shaft orders and mesh "
                  "harmonics are diagonal lines, the bench resonance a vertical band.",
                  {"bench modes marked": ", ".join(f"{f:.1f}" for f in modes) + " Hz",
                   "speed range": f"{float(raw.rpm.min()):.0f}-{float(raw.rpm.max()):.0f} rpm",
                   "total power (mean over rpm)": f"{10 * np.log10(float(f11.mean())):.1f} dB"})
    marks = {"3×": 3.0} | {f"GMF{i}": float(order_of(stages, f"mesh{i}"))
                           for i in range(1, len(stages) + 1)}
    for n, name in zip((12, 14, 16), list(variants)[:3], strict=True):
        ds = variants[name]
        what = f"{n_cycles} " + " + ".join(CYCLE_DESCRIPTIONS.get(c, f"{c} cycles")
                                           for c in ds.attrs["cycles"].split())
        if ds.attrs["averaging"] != "block":
            what += f" ({ds.attrs['averaging']} average)"
        fig_power_waterfall(ds, out[f"fig{n}_png"], f"Fig. {n} — power spectrum of the "
                            f"residual\nafter averaging {what}", vmax=vmax, modes=modes)
        fig_order_waterfall(ds, out[f"fig{n + 1}_png"], f"Fig. {n + 1} — order spectrum of "
                            f"the residual\nafter averaging {what}", marks=marks)
        numbers = {f"{fam} removed": f"{float(ds.attenuation.sel(family=fam)):.1f} dB "
                   f"(band measure {float(ds.attenuation_band.sel(family=fam)):.1f} dB)"
                   for fam in ds.family.values}
        numbers |= _mode_numbers(ds)
        for fig, label in ((n, "power"), (n + 1, "order")):
            write_caption(out[f"fig{fig}_caption"], f"Residual {label} spectrum, {name} TSA",
                          f"paper Fig. {fig}",
                          f"GB1 torque after subtracting the block average of {what} "
                          f"(cycle order {ds.attrs['cycle_orders']}).", numbers)
    fig_mode_band(variants, out["mode_band_png"])
    numbers = {}
    for name, ds in variants.items():
        for m, f in enumerate(ds.mode_frequency.values):
            numbers[f"{name}, mode {f:.1f} Hz"] = f"{float(ds.mode_change.isel(mode=m)):+.2f} dB"
        if "cascade_attenuation" in ds:
            for fam in ds.family.values:
                numbers[f"{name}: {fam} joint vs cascade"] = (
                    f"{float(ds.attenuation.sel(family=fam)):.1f} dB vs "
                    f"{float(ds.cascade_attenuation.sel(family=fam)):.1f} dB (band measure "
                    f"{float(ds.attenuation_band.sel(family=fam)):.1f} vs "
                    f"{float(ds.cascade_attenuation_band.sel(family=fam)):.1f} dB)")
    write_caption(out["mode_band_caption"], "Does TSA remove a resonance?",
                  "extension (the paper's open question)",
                  "Change in dB of the power in the band around each bench mode, per rpm bin "
                  "and TSA variant; crosses mark bins where a removed family passes through "
                  "the band.", numbers)
