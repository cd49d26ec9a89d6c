"""Figures 7–10: speed and torque vs time in the ramp tests, both gearboxes' HSS."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr

from gbpipe.figures.style import new, save

__all__ = ["fig_speed", "fig_torque"]

_RPM = 60.0 / (2 * np.pi)


def _decimate(ds: xr.Dataset, max_points: int = 20000) -> xr.Dataset:
    step = max(1, ds.time.size // max_points)
    return ds.isel(time=slice(None, None, step))


def fig_speed(records: Sequence[xr.Dataset], stem, title: str) -> None:
    """HSS speed of GB1 and GB2 [rpm] vs time, measured-like, with the reference."""
    fig, axes = new(1, len(records), figsize=(4.0 * len(records), 3.6), squeeze=False)
    for ax, ds in zip(axes[0], records, strict=True):
        d = _decimate(ds)
        suffix = "_measured" if "speed_gb1_hss_measured" in d else ""
        ax.plot(d.time, d[f"speed_gb1_hss{suffix}"] * _RPM, lw=0.6, label="GB1 HSS")
        ax.plot(d.time, d[f"speed_gb2_hss{suffix}"] * _RPM, lw=0.6, alpha=0.8, label="GB2 HSS")
        ax.plot(d.time, d.speed_ref * _RPM, "k--", lw=0.8, label="reference")
        ax.set_title(f"{ds.attrs['test']} ({ds.attrs['profile']})")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("speed [rpm]")
        ax.legend(loc="best")
    fig.suptitle(title, fontsize=10)
    save(fig, stem)


def fig_torque(records: Sequence[xr.Dataset], stem, title: str) -> None:
    """Torque-meter torque of GB1 and GB2 HSS [kN·m] vs time, with the reference."""
    fig, axes = new(1, len(records), figsize=(4.0 * len(records), 3.6), squeeze=False)
    for ax, ds in zip(axes[0], records, strict=True):
        d = _decimate(ds)
        suffix = "_measured" if "torque_meter_driven_measured" in d else ""
        ax.plot(d.time, d[f"torque_meter_driven{suffix}"] / 1e3, lw=0.5, label="GB1 HSS (driven)")
        ax.plot(d.time, d[f"torque_meter_driving{suffix}"] / 1e3, lw=0.5, alpha=0.7,
                label="GB2 HSS (driving)")
        ax.plot(d.time, d.torque_ref / 1e3, "k--", lw=0.8, label="reference")
        ax.set_title(f"{ds.attrs['test']} ({ds.attrs['profile']})")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("torque [kN·m]")
        ax.legend(loc="best")
    fig.suptitle(title, fontsize=10)
    save(fig, stem)
