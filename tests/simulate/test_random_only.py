"""The random-only sweep of the exact separation metric (gbpipe.simulate.random_only):
the same noise realisation with the angle-locked excitation off, so that the sweep minus
it is exactly the harmonic part -- checked by superposition against two noise-free runs."""

from __future__ import annotations

import numpy as np
import pytest

from gbpipe.config import load
from gbpipe.harmonics import excitation_families
from gbpipe.simulate import random_only, sweep
from tests.conftest import ROOT

SIGNAL = "torque_meter_driven_measured"


@pytest.fixture(scope="module")
def cfg():
    # a 4 s piece of sweep (too short for the TSA checks of a full load: set afterwards)
    c = load(ROOT / "config" / "config.yaml", ROOT / "config" / "ci.yaml")
    return {**c, "sweep": {**c["sweep"], "rpm_start": 600.0, "rpm_end": 660.0,
                           "duration": 4.0, "settle": 0.5}}


def _angle_locked_share(x: np.ndarray, theta: np.ndarray, t: np.ndarray,
                        orders: list[float]) -> float:
    """Share of the power of ``x`` that lines at ``orders`` of the shaft angle ``theta``
    explain, with amplitudes cubic in time (least squares, independent of gbpipe)."""
    u = 2 * (t - t[0]) / (t[-1] - t[0]) - 1
    cols = [np.ones_like(t)]
    for o in orders:
        for trig in (np.cos(o * theta), np.sin(o * theta)):
            cols += [trig * np.polynomial.legendre.legval(u, np.eye(4)[d]) for d in range(4)]
    a = np.column_stack(cols)
    fit = a @ np.linalg.lstsq(a, x - x.mean(), rcond=None)[0]
    return float(np.sum(fit**2) / np.sum((x - x.mean()) ** 2))


def test_only_the_excitation_is_switched_off(cfg):
    quiet = random_only(cfg)
    assert all(s["amplitude"] == 0 for s in quiet["excitation"]["shaft_orders"])
    assert all(m["amplitude"] == 0 for m in quiet["excitation"]["mesh"])
    assert quiet["seed"] == cfg["seed"]
    assert any(s["amplitude"] > 0 for s in cfg["excitation"]["shaft_orders"])  # unchanged
    # the converters' pulsating torque is angle-locked too: off; the broadband ripple and
    # the sensor noise stay
    for section in (quiet["noise"], quiet["sweep"]["noise"]):
        for spec in section["motor_ripple"].values():
            assert spec["pulsating"] and all(p["amplitude"] == 0 for p in spec["pulsating"])
            assert spec["broadband"] > 0
        assert section["sensor"] == cfg["noise"]["sensor"]


def test_sweep_minus_random_only_is_the_harmonic_part(cfg):
    full, rnd = sweep(cfg), sweep(random_only(cfg))
    # the families of the sweep's own noise section (its pulsating torque: the motor family)
    families = excitation_families({**cfg, "noise": cfg["sweep"]["noise"]})
    assert families["motor"]  # the default's converters pulsate
    orders = [float(o) for v in families.values() for o in v]
    keep = full.time.values > 1.0  # past the start of the excitation's response
    t, theta = full.time.values[keep], full.angle_gb1_hss.values[keep]
    # the same draws: the clean signals (set-points and ripple, no sensor noise) differ by
    # the pulsating torque's response only, lines at the motor orders
    clean = (full.torque_meter_driven.values - rnd.torque_meter_driven.values)[keep]
    assert np.std(clean) > 1.0  # N m
    assert _angle_locked_share(clean, theta, t, [float(o) for o in families["motor"]]) > 0.999
    # the difference is angle-locked: lines at the excited orders of the HSS angle explain
    # it, and explain almost none of the random-only record
    harmonic = (full[SIGNAL].values - rnd[SIGNAL].values)[keep]
    assert np.std(harmonic) > 1.0  # N m: the excitation is there
    assert _angle_locked_share(harmonic, theta, t, orders) > 0.999
    assert _angle_locked_share(rnd[SIGNAL].values[keep], theta, t, orders) < 0.05


def test_a_slice_without_a_sweep_is_quieted_too(cfg):
    # a workflow job for a test record gets the configuration without the sweep section
    piece = {k: v for k, v in cfg.items() if k != "sweep"}
    quiet = random_only(piece)
    assert "sweep" not in quiet
    assert quiet["excitation"] == random_only(cfg)["excitation"]
    assert quiet["noise"] == random_only(cfg)["noise"]
    assert all(p["amplitude"] == 0 for spec in quiet["noise"]["motor_ripple"].values()
               for p in spec["pulsating"])
