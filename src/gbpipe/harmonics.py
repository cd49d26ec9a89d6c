"""The harmonic-removal stage on the sweep: spectra before and after TSA, and metrics.

Which excitation orders a TSA variant removes is decided exactly: a configured excitation
order ``o`` (shaft order or mesh harmonic, a Fraction from the teeth) is removed by a
cycle of order ``c`` when ``o / c`` is a whole number. Those are the families whose
attenuation is measured and whose crossings of a structural mode are flagged.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from fractions import Fraction
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.kinematics import order_of

__all__ = ["structural_modes", "excitation_families", "removed_families", "cycle_orders",
           "waterfalls", "remove", "variant_metrics"]


def structural_modes(freqs: Sequence[float], f_min: float, f_max: float,
                     merge_within: float) -> np.ndarray:
    """Mode frequencies [Hz] to watch, close pairs merged into one band.

    The bench's twin gearboxes give pairs of modes a fraction of a hertz apart (61.9 and
    62.4 Hz); one band covers both, so pairs closer than ``merge_within`` become their mean.
    """
    f = np.sort(np.asarray(freqs, dtype=float))
    f = f[(f > f_min) & (f < f_max)]
    groups: list[list[float]] = []
    for v in f:
        if groups and v - groups[-1][-1] < merge_within:
            groups[-1].append(v)
        else:
            groups.append([v])
    return np.array([np.mean(g) for g in groups])


def cycle_orders(stages: Sequence[Mapping[str, Any]], cycles: Sequence[str]) -> list[Fraction]:
    """Exact HSS orders of named cycles (``hss``, ``carrier2``, ``mesh2`` …)."""
    return [order_of(stages, c) for c in cycles]


def excitation_families(cfg: Mapping[str, Any]) -> dict[str, list[Fraction]]:
    """Orders of every configured excitation, grouped by source.

    Returns
    -------
    dict
        ``"shaft"`` → HSS orders of the shaft excitation; ``"mesh<k>"`` → the harmonics of
        stage k's mesh order, all as Fractions.
    """
    stages = cfg["gearbox"]["stages"]
    exc = cfg["excitation"]
    fam = {"shaft": [Fraction(s["order"]).limit_denominator(1000)
                     for s in exc["shaft_orders"] if s["amplitude"] > 0]}
    for m in exc["mesh"]:
        o = order_of(stages, f"mesh{m['stage']}")
        fam[f"mesh{m['stage']}"] = [h * o for h, w in enumerate(m["harmonics"], start=1)
                                    if w > 0 and m["amplitude"] > 0]
    return {k: v for k, v in fam.items() if v}


def removed_families(families: Mapping[str, Sequence[Fraction]],
                     cycles: Sequence[Fraction]) -> dict[str, list[Fraction]]:
    """The part of each family that is a whole multiple of one of the cycles."""
    out = {}
    for name, orders in families.items():
        kept = [o for o in orders if any((o / c).denominator == 1 for c in cycles)]
        if kept:
            out[name] = kept
    return out


def waterfalls(x: np.ndarray, fs: float, pulse_times: np.ndarray, spec: Mapping[str, Any],
               *, pulses_per_rev: int = 1, units: str = "N m",
               long_name: str = "torque") -> xr.Dataset:
    """Power spectrum vs rpm and order spectrum vs rpm of one signal.

    Variables ``power`` (rpm, frequency) and ``order_power`` (order_rpm, order) with their
    averaging counts; the order spectrum has its own rpm bins (``order_rpm``) because its
    frames are whole revolutions.
    """
    from gbpipe.spectra import order_spectrum_vs_rpm, power_spectrum_vs_rpm

    ps = power_spectrum_vs_rpm(x, fs, pulse_times=pulse_times, resolution=spec["resolution"],
                               window=spec["window"], overlap=spec["overlap"],
                               rpm_bins=spec["rpm_bins"], max_frequency=spec["max_frequency"],
                               pulses_per_rev=pulses_per_rev, units=units, long_name=long_name)
    os_ = order_spectrum_vs_rpm(x, fs, pulse_times, resolution=spec["order_resolution"],
                                max_order=spec["max_order"], window=spec["window"],
                                overlap=spec["overlap"], rpm_bins=spec["rpm_bins"],
                                pulses_per_rev=pulses_per_rev, units=units, long_name=long_name)
    os_ = os_.rename({"rpm": "order_rpm", "rpm_lower": "order_rpm_lower",
                      "rpm_upper": "order_rpm_upper", "power": "order_power",
                      "n_averages": "order_n_averages"})
    for v in ("order_rpm", "order_rpm_lower", "order_rpm_upper"):
        os_[v].attrs["long_name"] = os_[v].attrs.get("long_name", "rpm") + " (order spectrum)"
    return xr.merge([ps, os_])


def remove(x: np.ndarray, fs: float, pulse_times: np.ndarray, cycles: Sequence[Fraction],
           tsa_cfg: Mapping[str, Any], *, pulses_per_rev: int = 1,
           mode: str = "joint") -> np.ndarray:
    """TSA residual of ``x`` with one or several cycle families removed."""
    from gbpipe import tsa

    n = int(tsa_cfg["n_cycles"])
    opts = {"unbiased": bool(tsa_cfg.get("unbiased", False)),
            "averaging": tsa_cfg.get("averaging", "block")}
    if len(cycles) == 1:
        return tsa.residual(x, fs, pulse_times, cycles[0], n, pulses_per_rev, **opts)
    return tsa.residual_joint(x, fs, pulse_times, list(cycles), n, pulses_per_rev,
                              mode=mode, **opts)


def variant_metrics(before: np.ndarray, after: np.ndarray, fs: float,
                    pulse_times: np.ndarray, families: Mapping[str, Sequence[Fraction]],
                    modes: Sequence[float], spec: Mapping[str, Any], *,
                    pulses_per_rev: int = 1) -> xr.Dataset:
    """Attenuation per removed family and band change per mode, overall and per rpm bin.

    The rpm dimension is renamed ``metric_rpm`` so the metrics can sit beside spectra.
    """
    from gbpipe.removal import removal_metrics

    fam = {k: [float(o) for o in v] for k, v in families.items()}
    ds = removal_metrics(before, after, fs, pulse_times, fam, list(modes),
                         rpm_bins=spec["metric_rpm_bins"], half_width=spec["mode_half_width"],
                         pulses_per_rev=pulses_per_rev)
    ren = {v: f"metric_{v}" for v in ("rpm", "rpm_lower", "rpm_upper") if v in ds.variables}
    return ds.rename(ren)
