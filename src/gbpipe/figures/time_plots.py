"""Figures 7–10: speed and torque vs time in the ramp tests, both gearboxes' HSS.

:func:`ramp_test_figures` draws all four with their report captions from the outputs of the
``simulate`` stage.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr

from gbpipe.figures.captions import write_caption
from gbpipe.figures.style import new, save
from gbpipe.units import RPM_PER_RAD_S

__all__ = ["fig_speed", "fig_torque", "ramp_test_figures"]

_RPM = 60.0 / (2 * np.pi)


def _envelope(t: np.ndarray, x: np.ndarray, bins: int = 1000
              ) -> tuple[np.ndarray, np.ndarray]:
    """Min-max envelope of ``x(t)`` in ``bins`` equal runs of samples, as one line.

    Each run contributes its minimum and its maximum (in their order of time), so the line
    covers the band the full record covers in each run: a panel ~500 pixels wide
    looks the same as with every sample, while a strided subset would show a random
    selection of the noise peaks. 2 ``bins`` points instead of up to 325 000 per line:
    drawing, the legend's search for the emptiest corner and the PDF are 10x lighter.
    """
    if x.size <= 2 * bins:
        return t, x
    m = x.size // bins
    runs = x[:m * bins].reshape(bins, m)
    first = np.arange(bins) * m
    # the samples of each run's minimum and maximum, and the few left after the last run
    idx = np.sort(np.concatenate([first + runs.argmin(axis=1), first + runs.argmax(axis=1),
                                  np.arange(m * bins, x.size)]))
    return t[idx], x[idx]


def _panels(records: Sequence[xr.Dataset], stem, title: str, lines, reference: str,
            scale: float, ylabel: str) -> None:
    """One panel per record: measured-like signals (``lines``: name, label, width, alpha)
    and the reference, all times ``scale``, against time [s]."""
    fig, axes = new(1, len(records), figsize=(4.0 * len(records), 3.6), squeeze=False)
    for ax, d in zip(axes[0], records, strict=True):
        t = d.time.values
        suffix = "_measured" if f"{lines[0][0]}_measured" in d else ""
        for name, label, lw, alpha in lines:
            ax.plot(*_envelope(t, d[f"{name}{suffix}"].values * scale), lw=lw, alpha=alpha,
                    label=label)
        ax.plot(*_envelope(t, d[reference].values * scale), "k--", lw=0.8, label="reference")
        ax.set_title(f"{d.attrs['test']} ({d.attrs['profile']})")
        ax.set_xlabel("time [s]")
        ax.set_ylabel(ylabel)
        ax.legend(loc="best")
    fig.suptitle(title, fontsize=10)
    save(fig, stem)


def fig_speed(records: Sequence[xr.Dataset], stem, title: str) -> None:
    """HSS speed of GB1 and GB2 [rpm] vs time, measured-like, with the reference."""
    _panels(records, stem, title, [("speed_gb1_hss", "GB1 HSS", 0.6, None),
                                   ("speed_gb2_hss", "GB2 HSS", 0.6, 0.8)],
            "speed_ref", _RPM, "speed [rpm]")


def fig_torque(records: Sequence[xr.Dataset], stem, title: str) -> None:
    """Torque-meter torque of GB1 and GB2 HSS [kN·m] vs time, with the reference."""
    _panels(records, stem, title, [("torque_meter_driven", "GB1 HSS (driven)", 0.5, None),
                                   ("torque_meter_driving", "GB2 HSS (driving)", 0.5, 0.7)],
            "torque_ref", 1e-3, "torque [kN·m]")


def _final(ds: xr.Dataset, name: str) -> float:
    """Mean of ``ds[name]`` over the last second of the record: its final level."""
    return float(ds[name].isel(time=slice(-int(ds.attrs["sample_rate"]), None)).mean())


def _test_numbers(records: Sequence[xr.Dataset]) -> dict[str, str]:
    """Caption lines: final GB1 HSS speed [rpm], final driven torque [kN·m], noise rms."""
    numbers = {}
    for ds in records:
        tag = f"{ds.attrs['test']} ({ds.attrs['profile']})"
        numbers[f"{tag}: final GB1 HSS speed"] = (
            f"{_final(ds, 'speed_gb1_hss') * RPM_PER_RAD_S:.2f} rpm")
        numbers[f"{tag}: driven torque meter, final"] = (
            f"{_final(ds, 'torque_meter_driven') / 1e3:.3f} kN·m")
        if "torque_meter_driven_measured" in ds:
            numbers[f"{tag}: harmonic + noise torque rms"] = (
                f"{float((ds.torque_meter_driven_measured - ds.torque_meter_driven).std()):.0f}"
                " N·m")
    return numbers


def ramp_test_figures(speed: Sequence[xr.Dataset], torque: Sequence[xr.Dataset],
                 out: Mapping[str, str | os.PathLike]) -> None:
    """Figures 7-10: speed and torque vs time in the speed- and torque-ramp tests.

    Parameters
    ----------
    speed, torque : sequence of xarray.Dataset
        ``simulate`` outputs of the speed-ramp and of the torque-ramp tests (speeds
        [rad/s], torques [N·m], attribute ``sample_rate`` [Hz]); one panel each.
    out : mapping
        Output paths by name: ``fig<n>_png`` and ``fig<n>_caption`` for n = 7..10 (the
        other formats go beside each PNG). Captions give the final GB1 HSS speed [rpm], the final
        driven torque-meter torque [kN·m] (means over the last second) and the rms of
        harmonics plus noise on the driven torque meter [N·m].
    """
    figs = [(7, fig_speed, speed, "speed vs time, speed-ramp tests"),
            (8, fig_torque, speed, "torque vs time, speed-ramp tests"),
            (9, fig_speed, torque, "speed vs time, torque-ramp tests"),
            (10, fig_torque, torque, "torque vs time, torque-ramp tests")]
    for n, plot, records, what in figs:
        paper = f"Fig. {n}"
        plot(records, out[f"fig{n}_png"], f"{paper} — {what} (GB1 driven, GB2 driving)")
        write_caption(out[f"fig{n}_caption"], what.capitalize(), f"paper {paper}",
                      "Measured-like HSS signals of both gearboxes (with shaft and mesh "
                      "harmonics and sensor noise) and the reference.",
                      _test_numbers(records))
