"""Figures 11–17: power and order spectra vs rpm, raw and after TSA; mode-band check."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import xarray as xr

from gbpipe.figures.style import new, save

__all__ = ["fig_power_waterfall", "fig_order_waterfall", "fig_mode_band"]


def _db(power: xr.DataArray) -> np.ndarray:
    return 10 * np.log10(np.maximum(power.values, 1e-30))


def _mesh(ax, x, y, z, vmax, dyn, label):
    m = ax.pcolormesh(x, y, z, shading="nearest", cmap="viridis", vmin=vmax - dyn, vmax=vmax,
                      rasterized=True)
    return m


def fig_power_waterfall(ds: xr.Dataset, stem, title: str, *, vmax: float | None = None,
                        dynamic_range: float = 70.0, modes=()) -> float:
    """Power spectrum vs rpm (frequency on x, rpm on y), in dB re 1 (N·m)²."""
    fig, ax = new(figsize=(7.0, 4.6))
    z = _db(ds.power)
    vmax = float(np.nanmax(z)) if vmax is None else vmax
    m = _mesh(ax, ds.frequency, ds.rpm, z, vmax, dynamic_range, "")
    for f in modes:
        ax.axvline(f, color="w", lw=0.6, ls="--")
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("HSS speed [rpm]")
    ax.set_title(title)
    fig.colorbar(m, ax=ax, label=f"power [dB re 1 {ds.power.attrs.get('units', '')}]")
    save(fig, stem)
    return vmax


def fig_order_waterfall(ds: xr.Dataset, stem, title: str, *, vmax: float | None = None,
                        dynamic_range: float = 70.0, marks: Mapping[str, float] | None = None
                        ) -> float:
    """Order spectrum vs rpm (order on x, rpm on y), in dB."""
    fig, ax = new(figsize=(7.0, 4.6))
    z = _db(ds.order_power)
    vmax = float(np.nanmax(z)) if vmax is None else vmax
    m = _mesh(ax, ds.order, ds.order_rpm, z, vmax, dynamic_range, "")
    for label, o in (marks or {}).items():
        ax.axvline(o, color="w", lw=0.5, ls=":")
        ax.annotate(label, (o, 1.0), xycoords=("data", "axes fraction"), rotation=90,
                    va="top", ha="right", fontsize=7, color="w")
    ax.set_xlabel("order of the HSS [-]")
    ax.set_ylabel("HSS speed [rpm]")
    ax.set_title(title)
    fig.colorbar(m, ax=ax, label=f"power [dB re 1 {ds.order_power.attrs.get('units', '')}]")
    save(fig, stem)
    return vmax


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
        ax.set_title(f"mode {f:.1f} Hz ± {float(first.attrs.get('half_width', 4.0)):.0f} Hz",
                     fontsize=8)
        ax.legend(fontsize=6, ncol=2, loc="lower left")
    axes[-1, 0].set_xlabel("HSS speed [rpm]")
    fig.suptitle("Resonance bands after TSA (x: a removed family crosses the band; "
                 "grey: ±1 dB)", fontsize=9)
    save(fig, stem)
