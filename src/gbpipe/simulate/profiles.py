"""Reference profiles of the test campaigns: square and tapered steps, speed sweep.

A test holds the nominal point for ``settle`` seconds, moves one step away from it
(``+step`` for ``*_up``, ``−step`` for ``*_down``), holds ``hold`` seconds, comes back and
holds again. A square step is ideal; a tapered step ramps at the bench's rate, i.e. the
full range (1980 rpm, 40 kN·m) in ``ramp_time`` (90 s): 50 rpm in 2.27 s, 5 kN·m in
11.25 s.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["TESTS", "PROFILES", "RPM", "check_campaign", "check_sweep", "check_excitation",
           "step_reference", "ramp_rate", "sweep_reference", "test_duration"]

TESTS = ("speed_up", "speed_down", "torque_up", "torque_down")
PROFILES = ("square", "tapered")
RPM = 2 * np.pi / 60.0  # rad/s per rev/min


def _err(field: str, msg: str) -> ValueError:
    from gbpipe.config import ConfigError

    return ConfigError(f"config field '{field}': {msg}")


def check_test(test: str, profile: str) -> None:
    """Refuse an unknown test or profile name."""
    if test not in TESTS:
        raise ValueError(f"test: unknown test {test!r}; use one of {', '.join(TESTS)}")
    if profile not in PROFILES:
        raise ValueError(f"profile: unknown profile {profile!r}; use one of "
                         f"{', '.join(PROFILES)}")


def ramp_rate(camp: Mapping[str, Any], quantity: str) -> float:
    """Tapered ramp rate: rpm/s for ``speed``, N·m/s for ``torque``."""
    fr = camp["full_range"]
    key = "speed_rpm" if quantity == "speed" else "torque"
    return float(fr[key]) / float(fr["ramp_time"])


def test_duration(camp: Mapping[str, Any], test: str, profile: str) -> float:
    """Record length [s] of one test."""
    quantity = test.split("_")[0]
    key = "speed_rpm" if quantity == "speed" else "torque"
    ramp = float(camp["step"][key]) / ramp_rate(camp, quantity) if profile == "tapered" else 0.0
    return float(camp["settle"]) + 2 * (ramp + float(camp["hold"]))


def highest_excitation_hz(cfg: Mapping[str, Any], rpm_max: float) -> float:
    """Highest frequency [Hz] of the configured shaft and mesh excitation at ``rpm_max``."""
    from gbpipe.kinematics import order_of

    exc = cfg.get("excitation")
    if not exc:
        return 0.0
    f_hss = rpm_max / 60.0
    orders = [float(s["order"]) for s in exc["shaft_orders"] if s["amplitude"] > 0]
    for m in exc["mesh"]:
        o = float(order_of(cfg["gearbox"]["stages"], f"mesh{m['stage']}"))
        orders.append(o * len(m["harmonics"]))
    return f_hss * max(orders, default=0.0)


def _check_rate(cfg: Mapping[str, Any], field: str, fs: float, rpm_max: float) -> None:
    f_max = highest_excitation_hz(cfg, rpm_max)
    if fs < 2.5 * f_max:
        raise _err(field, f"{fs:g} Hz is below 2.5 x the highest excitation frequency "
                          f"({f_max:.1f} Hz at {rpm_max:g} rpm); raise it to at least "
                          f"{2.5 * f_max:.0f} Hz or drop high mesh harmonics")


def check_campaign(cfg: Mapping[str, Any]) -> None:
    """Check the ``campaign`` section (durations, sample rate, steps) before simulating."""
    camp = cfg.get("campaign")
    if not camp:
        return
    for key in ("settle", "hold"):
        if float(camp[key]) < 0 or (key == "hold" and float(camp[key]) <= 0):
            raise _err(f"campaign.{key}", f"duration must be positive, got {camp[key]} s")
    if float(camp["step"]["speed_rpm"]) >= float(camp["nominal"]["speed_rpm"]):
        raise _err("campaign.step.speed_rpm", "a step down would stop the bench: keep it "
                   "below campaign.nominal.speed_rpm")
    nom, st, fr = camp["nominal"], camp["step"], camp["full_range"]
    if float(nom["speed_rpm"]) + float(st["speed_rpm"]) > float(fr["speed_rpm"]):
        raise _err("campaign.step.speed_rpm", "nominal + step exceeds the bench's full range")
    if float(nom["torque"]) + float(st["torque"]) > float(fr["torque"]):
        raise _err("campaign.step.torque", "nominal + step exceeds the bench's full range")
    rpm_max = float(nom["speed_rpm"]) + float(st["speed_rpm"])
    _check_rate(cfg, "campaign.sample_rate", float(camp["sample_rate"]), rpm_max)


def check_sweep(cfg: Mapping[str, Any]) -> None:
    """Check the ``sweep`` section before simulating."""
    sw = cfg.get("sweep")
    if not sw:
        return
    if float(sw["settle"]) < 0:
        raise _err("sweep.settle", f"duration must be >= 0, got {sw['settle']} s")
    if float(sw["duration"]) <= 0:
        raise _err("sweep.duration", f"duration must be positive, got {sw['duration']} s")
    if float(sw["rpm_end"]) == float(sw["rpm_start"]):
        raise _err("sweep.rpm_end", "a sweep needs rpm_end different from rpm_start")
    _check_rate(cfg, "sweep.sample_rate", float(sw["sample_rate"]),
                max(float(sw["rpm_start"]), float(sw["rpm_end"])))
    if "campaign" in cfg:
        rate = ramp_rate(cfg["campaign"], "speed")
        needed = abs(float(sw["rpm_end"]) - float(sw["rpm_start"])) / rate
        if float(sw["duration"]) < needed:
            raise _err("sweep.duration", f"{sw['duration']} s is faster than the bench's "
                       f"ramp rate ({rate:.1f} rpm/s): use at least {needed:.1f} s")


def check_excitation(cfg: Mapping[str, Any]) -> None:
    """Check that every excited mesh stage exists in the gearbox."""
    n = len(cfg["gearbox"]["stages"])
    for i, m in enumerate(cfg.get("excitation", {}).get("mesh", [])):
        if m["stage"] > n:
            raise _err(f"excitation.mesh[{i}].stage",
                       f"stage {m['stage']} does not exist in a {n}-stage gearbox")


def step_reference(camp: Mapping[str, Any], test: str, profile: str,
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time axis and speed/torque references of one test.

    Returns
    -------
    t : ndarray
        Sample times [s] at ``campaign.sample_rate``.
    speed_ref : ndarray
        HSS speed reference [rad/s].
    torque_ref : ndarray
        Torque reference [N·m] at the HSS.
    """
    check_test(test, profile)
    fs = float(camp["sample_rate"])
    duration = test_duration(camp, test, profile)
    n = int(round(duration * fs))
    t = np.arange(n) / fs
    quantity, direction = test.split("_")
    sign = 1.0 if direction == "up" else -1.0
    key = "speed_rpm" if quantity == "speed" else "torque"
    step = sign * float(camp["step"][key])
    ramp = abs(step) / ramp_rate(camp, quantity) if profile == "tapered" else 0.0
    t0, hold = float(camp["settle"]), float(camp["hold"])
    t1 = t0 + ramp + hold
    if ramp > 0:
        delta = np.interp(t, [0.0, t0, t0 + ramp, t1, t1 + ramp, duration],
                          [0.0, 0.0, step, step, 0.0, 0.0])
    else:
        # square: the sample at the step instant takes the new level (the simulator holds
        # u[k] over [k dt, (k+1) dt)); half a sample of slack absorbs rounding of k dt
        half = 0.5 / fs
        delta = np.where((t >= t0 - half) & (t < t1 - half), step, 0.0)
    nom = camp["nominal"]
    speed = np.full(n, float(nom["speed_rpm"]))
    torque = np.full(n, float(nom["torque"]))
    if quantity == "speed":
        speed = speed + delta
    else:
        torque = torque + delta
    return t, speed * RPM, torque


def sweep_reference(sw: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time axis, speed reference [rad/s] and torque reference [N·m] of the sweep."""
    fs = float(sw["sample_rate"])
    settle, dur = float(sw["settle"]), float(sw["duration"])
    n = int(round((settle + dur) * fs))
    t = np.arange(n) / fs
    rpm = np.interp(t, [0.0, settle, settle + dur],
                    [float(sw["rpm_start"]), float(sw["rpm_start"]), float(sw["rpm_end"])])
    return t, rpm * RPM, np.full(n, float(sw["torque"]))
