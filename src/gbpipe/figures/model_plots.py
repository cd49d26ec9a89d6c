"""Figures 3 and 4: Bode magnitude of the gearbox and of the bench."""

from __future__ import annotations

import numpy as np
import xarray as xr

from gbpipe.figures.style import new, save

__all__ = ["fig3_gearbox_bode", "fig4_bench_bode"]


def _mark_modes(ax, freqs, fmax):
    for f in np.asarray(freqs):
        if f <= fmax:
            ax.axvline(f, color="0.6", lw=0.6, ls=":")
            ax.annotate(f"{f:.0f} Hz", (f, 1), xycoords=("data", "axes fraction"),
                        rotation=90, va="top", ha="right", fontsize=7, color="0.4")


def fig3_gearbox_bode(gb: xr.Dataset, stem) -> None:
    """Bode magnitude of one gearbox, HSS torque → LSS speed (paper Fig. 3)."""
    fig, ax = new()
    mag = gb.frf_magnitude.sel(frf_input="torque_hss", frf_output="speed_lss")
    ax.semilogx(gb.frequency, mag, color="C0", lw=1.2, label="HSS torque → LSS speed")
    _mark_modes(ax, gb.mode_frequency.values, float(gb.frequency.max()))
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("magnitude [dB re 1 (rad/s)/(N·m)]")
    ax.set_title("Fig. 3 — single gearbox, HSS torque → LSS speed")
    ax.legend(loc="lower left")
    save(fig, stem)


def fig4_bench_bode(bench: xr.Dataset, stem) -> None:
    """Bode magnitude of the complete bench (paper Fig. 4): open-loop plant."""
    fig, axes = new(2, 1, figsize=(7.0, 6.0), sharex=True)
    f = bench.frequency
    pairs = [("motor_torque_driver", "speed_gb1_hss", "driving torque → driven HSS speed"),
             ("motor_torque_driver", "speed_gb2_hss", "driving torque → driving HSS speed"),
             ("motor_torque_driver", "speed_lss", "driving torque → LSS speed")]
    for i, (u, y, label) in enumerate(pairs):
        axes[0].semilogx(f, bench.plant_frf_magnitude.sel(plant_frf_input=u, plant_frf_output=y),
                         color=f"C{i}", lw=1.1, label=label)
    axes[0].set_ylabel("magnitude [dB re 1 (rad/s)/(N·m)]")
    axes[0].set_title("Fig. 4 — complete back-to-back bench (open loop)")
    axes[0].legend(loc="lower left")
    lower = [("motor_torque_driver", "torque_meter_driven", "driving torque → driven meter"),
             ("motor_torque_driven", "torque_meter_driven", "braking torque → driven meter")]
    for i, (u, y, label) in enumerate(lower):
        axes[1].semilogx(f, bench.plant_frf_magnitude.sel(plant_frf_input=u, plant_frf_output=y),
                         color=f"C{i + 3}", lw=1.1, label=label)
    axes[1].set_ylabel("magnitude [dB re 1 (N·m)/(N·m)]")
    axes[1].set_xlabel("frequency [Hz]")
    axes[1].legend(loc="lower left")
    for ax in axes:
        _mark_modes(ax, bench.plant_mode_frequency.values, float(f.max()))
    save(fig, stem)
