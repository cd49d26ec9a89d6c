"""Tests of gbpipe.harmonics.vkf against hand-built records (:mod:`removal_signals`):
known modulated harmonics on a known sweep, white noise of known power, and the
analytic response of the second-order Vold-Kalman envelope filter."""

from __future__ import annotations

import numpy as np
import pytest
from removal_signals import FAMILIES, LINES, constant_speed, db, inner, sweep

from gbpipe.harmonics.vkf import residual_vkf, structural_weight


@pytest.fixture(scope="module")
def clean():
    return sweep(noise=0.0)


def test_modulated_harmonics_removed_by_60_db(clean):
    r = residual_vkf(clean["x"], clean["fs"], clean["pulses"], FAMILIES, bandwidth=1.0)
    m = inner(clean["t"], clean["pulses"], 1.0)
    assert db(np.mean(clean["h"][m] ** 2), np.mean(r[m] ** 2)) >= 60.0


def test_bandwidth_in_orders_also_removes(clean):
    r = residual_vkf(clean["x"], clean["fs"], clean["pulses"], FAMILIES, bandwidth=0.1,
                     bandwidth_unit="order")
    m = inner(clean["t"], clean["pulses"], 1.0)
    assert db(np.mean(clean["h"][m] ** 2), np.mean(r[m] ** 2)) >= 60.0


@pytest.mark.parametrize("s", [1, 2])
def test_half_power_at_the_bandwidth(s):
    # A tone B Hz above order 3 at constant speed: the filter keeps 1/sqrt(2) of it
    # (|H(B)| = 1 / (1 + w (2 sin(pi B / fs))^(2s)) = 1/sqrt(2) by the weight's definition),
    # so the residual keeps 1 - 1/sqrt(2) of its amplitude.
    c = constant_speed(rpm=600.0)
    bw = 0.8
    f = 3 * c["f_rot"] + bw
    x = np.cos(2 * np.pi * f * c["t"])
    r = residual_vkf(x, c["fs"], c["pulses"], {"o": [3.0]}, bandwidth=bw, filter_order=s)
    m = inner(c["t"], c["pulses"], 8.0)
    kept = np.sqrt(np.mean((x - r)[m] ** 2) / np.mean(x[m] ** 2))
    assert kept == pytest.approx(1 / np.sqrt(2), rel=0.01)


def test_structural_weight_formula():
    # independent closed form for B << fs: w = (sqrt(2) - 1) (fs / (2 pi B))^(2s)
    w = structural_weight(1.0, 10_000.0, 2)
    assert w == pytest.approx((np.sqrt(2) - 1) * (10_000.0 / (2 * np.pi)) ** 4, rel=1e-6)


def test_residual_is_the_noise_minus_the_analytic_noise_capture():
    # White noise of variance s2: each order's band-pass (both sides of the spectrum)
    # takes 2 * s2 / fs * int |H|^2 df = 2 * s2 / fs * 2.076 B (s = 2), so the residual
    # minus the noise has power 4.15 K B s2 / fs for K separated orders.
    sw = sweep(noise=0.5)
    bw = 1.0
    r = residual_vkf(sw["x"], sw["fs"], sw["pulses"], FAMILIES, bandwidth=bw)
    m = inner(sw["t"], sw["pulses"], 1.0)
    err = np.mean((r - sw["res"])[m] ** 2)
    k = sum(len(v) for v in FAMILIES.values())
    integral = 3 * np.pi / (4 * np.sqrt(2)) / (np.sqrt(2) - 1) ** 0.25  # int |H|^2 / B
    expected = 2 * k * integral * bw * 0.25 / sw["fs"]
    assert db(err, expected) == pytest.approx(0.0, abs=1.0)


def test_mean_and_trend_are_kept_and_do_not_leak():
    # A large mean and ramp (a torque record's load) plus the harmonics: the residual
    # keeps the mean and ramp, and the harmonics still go by 60 dB.
    sw = sweep(noise=0.0)
    trend = 1.0e4 + 50.0 * sw["t"]
    r = residual_vkf(sw["h"] + trend, sw["fs"], sw["pulses"], FAMILIES, bandwidth=1.0)
    m = inner(sw["t"], sw["pulses"], 1.0)
    assert db(np.mean(sw["h"][m] ** 2), np.mean((r - trend)[m] ** 2)) >= 60.0


def test_input_not_modified_and_outside_span_unchanged(clean):
    x = clean["x"].copy()
    r = residual_vkf(x, clean["fs"], clean["pulses"], {"o": [LINES[2][0]]})
    np.testing.assert_array_equal(x, clean["x"])
    before = clean["t"] < clean["pulses"][0]
    np.testing.assert_array_equal(r[before], x[before])


def test_refuses_a_bandwidth_too_narrow_for_float64(clean):
    with pytest.raises(ValueError, match="too narrow"):
        residual_vkf(clean["x"], clean["fs"], clean["pulses"], FAMILIES, bandwidth=0.01)
    with pytest.raises(ValueError, match="bandwidth_unit"):
        residual_vkf(clean["x"], clean["fs"], clean["pulses"], FAMILIES,
                     bandwidth_unit="rpm")
