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

from gbpipe.units import RAD_S_PER_RPM

__all__ = ["TESTS", "PROFILES", "RPM", "check_test", "step_reference", "ramp_rate",
           "sweep_reference", "test_duration", "test_revolutions", "sweep_revolutions"]

TESTS = ("speed_up", "speed_down", "torque_up", "torque_down")
PROFILES = ("square", "tapered")
#: rad/s per rev/min (kept as a name of this module for its callers)
RPM = RAD_S_PER_RPM


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


def test_revolutions(camp: Mapping[str, Any], test: str, profile: str) -> float:
    """HSS revolutions [-] the speed reference of one test spans (its exact integral).

    The step's ramps are linear, so the step adds ``step × (ramp + hold)`` rpm·s whatever
    the profile (a square step has ``ramp = 0``).
    """
    check_test(test, profile)
    nominal = float(camp["nominal"]["speed_rpm"])
    revs = nominal * test_duration(camp, test, profile)
    if test.startswith("speed"):
        step = float(camp["step"]["speed_rpm"])
        ramp = step / ramp_rate(camp, "speed") if profile == "tapered" else 0.0
        revs += (1.0 if test == "speed_up" else -1.0) * step * (ramp + float(camp["hold"]))
    return revs / 60.0


def sweep_revolutions(sw: Mapping[str, Any]) -> float:
    """HSS revolutions [-] the sweep's speed reference spans (settle, then a linear ramp)."""
    start, end = float(sw["rpm_start"]), float(sw["rpm_end"])
    return (start * float(sw["settle"]) + 0.5 * (start + end) * float(sw["duration"])) / 60.0
