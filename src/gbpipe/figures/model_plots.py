"""Figures 3 and 4: Bode magnitude of the gearbox and of the bench.

:func:`model_figures` draws figures 3-5 (5: :func:`gbpipe.figures.topology.fig5_topology`)
with their report captions from the outputs of the ``model`` stage.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.figures.captions import write_caption
from gbpipe.figures.style import new, save
from gbpipe.figures.topology import fig5_topology

__all__ = ["fig3_gearbox_bode", "fig4_bench_bode", "model_figures"]


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


def _plot_pairs(ax, bench: xr.Dataset, pairs, first_color: int) -> None:
    """One open-loop plant FRF magnitude per (input, output, label), colours from C<n>."""
    for i, (u, y, label) in enumerate(pairs):
        ax.semilogx(bench.frequency,
                    bench.plant_frf_magnitude.sel(plant_frf_input=u, plant_frf_output=y),
                    color=f"C{i + first_color}", lw=1.1, label=label)


def fig4_bench_bode(bench: xr.Dataset, stem) -> None:
    """Bode magnitude of the complete bench (paper Fig. 4): open-loop plant."""
    fig, axes = new(2, 1, figsize=(7.0, 6.0), sharex=True)
    pairs = [("motor_torque_driver", "speed_gb1_hss", "driving torque → driven HSS speed"),
             ("motor_torque_driver", "speed_gb2_hss", "driving torque → driving HSS speed"),
             ("motor_torque_driver", "speed_lss", "driving torque → LSS speed")]
    _plot_pairs(axes[0], bench, pairs, first_color=0)
    axes[0].set_ylabel("magnitude [dB re 1 (rad/s)/(N·m)]")
    axes[0].set_title("Fig. 4 — complete back-to-back bench (open loop)")
    axes[0].legend(loc="lower left")
    lower = [("motor_torque_driver", "torque_meter_driven", "driving torque → driven meter"),
             ("motor_torque_driven", "torque_meter_driven", "braking torque → driven meter")]
    _plot_pairs(axes[1], bench, lower, first_color=3)
    axes[1].set_ylabel("magnitude [dB re 1 (N·m)/(N·m)]")
    axes[1].set_xlabel("frequency [Hz]")
    axes[1].legend(loc="lower left")
    for ax in axes:
        _mark_modes(ax, bench.plant_mode_frequency.values, float(bench.frequency.max()))
    save(fig, stem)


def _hz(values) -> str:
    """Caption text of frequencies [Hz], one decimal."""
    return ", ".join(f"{v:.1f}" for v in values) + " Hz"


def model_figures(gearbox: xr.Dataset, bench: xr.Dataset, model_cfg: Mapping[str, Any],
                  out: Mapping[str, str | os.PathLike]) -> None:
    """Figures 3 (gearbox Bode), 4 (bench Bode) and 5 (topology), with report captions.

    Parameters
    ----------
    gearbox : xarray.Dataset
        ``results/model/gearbox.nc``: FRF magnitude [dB], modes and undamped natural
        frequencies [Hz] of one gearbox.
    bench : xarray.Dataset
        ``results/model/bench.nc``: open-loop (``plant_``) FRF magnitude [dB] and modes
        [Hz], closed-loop (``closed_``) modes [Hz].
    model_cfg : mapping
        Validated configuration sections ``gearbox`` and ``bench`` (topology, and the
        gearbox name in the Fig. 5 caption).
    out : mapping
        Output paths by name: ``fig<n>_png`` and ``fig<n>_caption`` for n = 3, 4, 5 (the
        other formats go beside each PNG).
    """
    fig3_gearbox_bode(gearbox, out["fig3_png"])
    fig4_bench_bode(bench, out["fig4_png"])
    fig5_topology(model_cfg, out["fig5_png"])
    write_caption(out["fig3_caption"], "Single gearbox: HSS torque to LSS speed",
                  "paper Fig. 3",
                  "Bode magnitude of one gearbox with free ends; each gear stage adds a "
                  "resonance, the elastic housing mount one more.",
                  {"modes": _hz(gearbox.mode_frequency.values),
                   "undamped (K, M)": _hz(gearbox.undamped_frequency.values)})
    closed = bench.closed_mode_frequency.values
    write_caption(out["fig4_caption"], "Complete back-to-back bench", "paper Fig. 4",
                  "Bode magnitude of the open-loop bench from the driving motor torque to "
                  "speeds and torque meters.",
                  {"open-loop modes": _hz(bench.plant_mode_frequency.values),
                   "closed-loop modes": _hz(closed),
                   "bench resonance near 60 Hz": _hz(closed[(closed > 50) & (closed < 75)])})
    write_caption(out["fig5_caption"], "Model topology",
                  "paper Fig. 5 (Simscape model), extended to the bench",
                  "Bodies, shafts, couplings with torque meters, gear stages and housing "
                  "mounts, drawn from the configuration.",
                  {"gearbox": model_cfg["gearbox"]["name"]})
