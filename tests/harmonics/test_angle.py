"""Tests of gbpipe.harmonics tacho, angle and order tracking against analytic sweeps
(exact angle, exact pulse times)."""

from __future__ import annotations

import numpy as np
import pytest
from harmonic_sweeps import FS, MESH, make_sweep
from scipy import ndimage

from gbpipe import harmonics
from gbpipe.errors import DataError, PulseError
from gbpipe.harmonics.angle import (
    angle_map,
    evaluate_spline,
    resample_map_to_angle,
    spline_coefficients,
)
from gbpipe.harmonics.tracking import uniform_projection


@pytest.fixture(scope="module")
def sw():
    return make_sweep(noise=0.0)


def tacho_signal(theta: np.ndarray, width: float, noise: float, seed: int = 0) -> np.ndarray:
    """0/5 V square wave of the true angle, rising through 2.5 V exactly at 2 pi k."""
    v = 2.5 * (1.0 + np.tanh(np.sin(theta) / width))
    return v + noise * np.random.default_rng(seed).standard_normal(theta.size)


# --------------------------------------------------------------------------- pulses
def test_pulse_times_sub_sample_accuracy(sw):
    p = sw["pulses"]
    v = tacho_signal(sw["theta"], width=0.05, noise=0.0)
    got = harmonics.pulse_times_from_tacho(v, FS)
    assert got.size == p.size
    # Edge odd about its centre: linear interpolation at 50 % is exact to O(dt^3).
    assert np.max(np.abs(got - p)) < 0.02 / FS


def test_pulse_times_falling_edge_and_t0(sw):
    p = sw["pulses"]
    v = tacho_signal(sw["theta"], width=0.05, noise=0.0)
    got = harmonics.pulse_times_from_tacho(-v, FS, edge="falling", t0=3.0)
    np.testing.assert_allclose(got, p + 3.0, atol=0.02 / FS)


def test_hysteresis_prevents_double_pulses(sw):
    p = sw["pulses"]
    # Slow edges (tens of samples) with noise: without hysteresis the noise re-crosses.
    v = tacho_signal(sw["theta"], width=0.5, noise=0.05, seed=1)
    good = harmonics.pulse_times_from_tacho(v, FS)
    assert good.size == p.size
    assert np.max(np.abs(good - p)) < 2.0 / FS
    chattering = harmonics.pulse_times_from_tacho(v, FS, hysteresis=0.0)
    assert chattering.size > p.size
    with pytest.raises(ValueError, match="extra pulse"):
        harmonics.check_pulse_times(chattering)


def test_tacho_threshold_outside_range():
    v = np.sin(np.linspace(0, 20, 1000))
    with pytest.raises(ValueError, match="threshold=.*outside the range of tacho"):
        harmonics.pulse_times_from_tacho(v, 100.0, threshold=3.0)


# --------------------------------------------------------------------------- checks
def test_check_passes_clean_sweep(sw):
    res = harmonics.check_pulse_times(sw["pulses"])
    np.testing.assert_array_equal(res.pulse_times, sw["pulses"])
    assert res.missing_after.size == 0 and res.extra.size == 0


def test_check_repairs_missing_with_warning(sw):
    p = sw["pulses"]
    broken = np.delete(p, [30, 200, 201])  # one single gap and one double gap
    with pytest.raises(PulseError, match="3 missing pulse") as err:
        harmonics.check_pulse_times(broken)
    assert err.value.sample == 29  # the pulse before the first gap
    with pytest.warns(UserWarning, match="inserted 3 missing"):
        res = harmonics.check_pulse_times(broken, repair=True)
    assert res.pulse_times.size == p.size
    # PCHIP through the neighbours follows the acceleration (equal spacing in the
    # double gap would be off by 4e-3 of an interval here).
    err = np.abs(res.pulse_times - p)
    assert err[30] < 1e-4 * (p[31] - p[30])
    assert err[200:202].max() < 1e-3 * (p[201] - p[200])


def test_check_repairs_extra_with_warning(sw):
    p = sw["pulses"]
    broken = np.sort(np.append(p, [p[10] + 0.3 * (p[11] - p[10]), p[99] + 1e-4]))
    with pytest.raises(PulseError, match="2 extra pulse") as err:
        harmonics.check_pulse_times(broken)
    assert err.value.sample == 11  # the pulse inserted after p[10]
    with pytest.warns(UserWarning, match="deleted 2 extra"):
        res = harmonics.check_pulse_times(broken, repair=True)
    # The pulse 0.1 ms after p[99]: either of the pair may go; the other is kept.
    np.testing.assert_allclose(res.pulse_times, p, atol=1.01e-4)


def test_check_rejects_jitter_even_with_repair(sw):
    p = sw["pulses"].copy()
    p[50] += 0.35 * (p[51] - p[50])
    with pytest.raises(PulseError, match="jittery") as err:
        harmonics.check_pulse_times(p, repair=True)
    assert err.value.sample == 49  # the interval 49 -> 50 is the first one stretched


def test_check_rejects_non_increasing():
    with pytest.raises(PulseError, match="strictly increasing") as err:
        harmonics.check_pulse_times([0.0, 1.0, 1.0, 2.0, 3.0])
    assert err.value.sample == 2
    with pytest.raises(PulseError, match="at least 3 pulses"):
        harmonics.check_pulse_times([0.0, 1.0])


# --------------------------------------------------------------------------- angle
def test_angle_and_speed_match_analytic(sw):
    p = sw["pulses"]
    inside = (sw["t"] >= p[0]) & (sw["t"] <= p[-1])
    t = sw["t"][inside]
    true = sw["theta"][inside] - 2 * np.pi  # first pulse is at theta = 2 pi
    err = {m: np.max(np.abs(harmonics.shaft_angle(t, p, method=m) - true))
           for m in ("pchip", "cubic", "linear")}
    # Linear: alpha dt^2 / 8 between pulses; cubics are orders of magnitude better.
    assert err["linear"] > 1e-3
    assert err["pchip"] < err["linear"] / 30
    assert err["cubic"] < err["linear"] / 300
    speed = harmonics.shaft_speed(t, p)
    true_speed = 2 * np.pi * sw["rpm"][inside] / 60
    assert np.max(np.abs(speed / true_speed - 1)) < 2e-3
    assert np.isnan(harmonics.shaft_angle([p[0] - 0.01], p)[0])


def test_resample_to_angle_is_exact_for_orders(sw):
    x = np.cos(3 * sw["theta"]) + 0.5 * np.cos(MESH * sw["theta"])
    theta, xa = harmonics.resample_to_angle(x, FS, sw["pulses"])
    th_true = theta + 2 * np.pi
    expect = np.cos(3 * th_true) + 0.5 * np.cos(MESH * th_true)
    assert np.max(np.abs(xa - expect)) < 2e-3
    # Back to time: round trip reproduces x inside the pulse span.
    spr = int(round(2 * np.pi / theta[1]))
    back = harmonics.resample_to_time(xa, spr, x.size, FS, sw["pulses"])
    ok = np.isfinite(back)
    assert ok.sum() > 0.9 * x.size
    assert np.max(np.abs(back[ok] - x[ok])) < 2e-3


def test_resample_to_angle_does_not_alias(sw):
    # A fixed 1500 Hz tone is above the order band of 64 samples/rev at every speed
    # (32 orders x 18.7 Hz = 600 Hz): it must be filtered out, not folded in.
    tone = np.cos(2 * np.pi * 1500.0 * sw["t"])
    order3 = np.cos(3 * sw["theta"])
    theta, xa = harmonics.resample_to_angle(tone + order3, FS, sw["pulses"], samples_per_rev=64)
    assert round(2 * np.pi / theta[1]) == 64
    # Compare against the order-3 line alone (away from the record ends: FIR edges).
    core = slice(64 * 5, -64 * 5)
    ref = np.cos(3 * (theta + 2 * np.pi))
    assert np.sqrt(np.mean((xa[core] - ref[core]) ** 2)) < 1e-2  # tone power 0.5 -> gone


@pytest.mark.parametrize("n", [1, 2, 3, 4, 7, 40_000])
def test_evaluate_spline_equals_map_coordinates(n):
    # the chunked four-tap evaluation against scipy's, mirror boundary, the ends included
    # (and more positions than one chunk, in no order)
    rng = np.random.default_rng(n)
    coef = spline_coefficients(rng.standard_normal(n))
    pos = np.concatenate([rng.uniform(0, n - 1, 3 * n + 50), [0.0, n - 1.0, 0.5 * (n - 1)]])
    ref = ndimage.map_coordinates(coef, pos[None, :], order=3, prefilter=False,
                                  mode="mirror")
    np.testing.assert_allclose(evaluate_spline(coef, pos), ref, rtol=0, atol=1e-14)


def test_channels_resample_and_track_as_each_alone(sw):
    # several signals of one record at once: one angle grid, the same result as one by one
    x = np.c_[sw["x"], np.cos(3 * sw["theta"]), np.sin(MESH * sw["theta"])]
    amap = angle_map(x[:, 0], FS, sw["pulses"], 1, "pchip", 0.0)[-1]
    theta, xa = resample_map_to_angle(x, amap, 64)
    assert xa.shape == (theta.size, 3)
    segments = [[0.0, 40 * np.pi], [10.0, 200.0], [0.0, 1.0]]  # the last: too short, NaN
    amp = harmonics.order_amplitudes(x, FS, sw["pulses"], [3, MESH], segments=segments)
    assert amp.shape == (3, 3, 2)
    for j in range(3):
        np.testing.assert_array_equal(
            xa[:, j], resample_map_to_angle(x[:, j], amap, 64)[1])
        np.testing.assert_array_equal(amp[:, j], harmonics.order_amplitudes(
            x[:, j], FS, sw["pulses"], [3, MESH], segments=segments))
    assert np.isnan(amp[2]).all()


def test_order_amplitudes_exact_non_integer(sw):
    x = 0.7 * np.cos(MESH * sw["theta"] + 0.4) + np.cos(3 * sw["theta"] - 0.5)
    amp = harmonics.order_amplitudes(x, FS, sw["pulses"], [3, MESH])
    # Angle origin at the first pulse (true theta = 2 pi): phases shift by 2 pi m.
    expect = np.array([np.exp(1j * (-0.5 + 3 * 2 * np.pi)),
                       0.7 * np.exp(1j * (0.4 + MESH * 2 * np.pi))])
    np.testing.assert_allclose(amp, expect, atol=5e-3)


def test_order_spectrum_line_height(sw):
    x = 2.0 * np.cos(3 * sw["theta"])
    spec = harmonics.order_spectrum(x, FS, sw["pulses"], resolution=0.05, max_order=10,
                                 units="N m", long_name="torque")
    peak = float(spec.sel(order=3.0, method="nearest"))
    assert peak == pytest.approx(2.0**2 / 2, rel=0.01)
    assert spec.attrs["units"] == "N2 m2"
    assert spec.order.attrs["units"] == "1"


def test_orders_reject_bad_input(sw):
    x = sw["x"]
    late = sw["pulses"] + 1.0
    with pytest.raises(PulseError, match="pulse_times.*span") as err:
        harmonics.resample_to_angle(x, FS, late)
    assert err.value.sample == int(np.argmax(late > (x.size - 1) / FS))
    gap = x.copy()
    gap[1234:1240] = np.nan
    with pytest.raises(DataError, match="6 NaN/inf samples") as err:
        harmonics.resample_to_angle(gap, FS, sw["pulses"])
    assert err.value.sample == 1234
    with pytest.raises(ValueError, match="method must be one of"):
        harmonics.shaft_angle([1.0], sw["pulses"], method="spline")
    with pytest.raises(DataError, match="x: must be a 1-D array"):
        harmonics.resample_to_angle(np.c_[x, x], FS, sw["pulses"])
    with pytest.raises(ValueError, match="orders must be > 0"):
        harmonics.order_amplitudes(x, FS, sw["pulses"], [3, -1])


def test_uniform_projection_equals_the_direct_sum():
    # the blocked (twiddle-factored) projection against the plain sum of x exp(-1j m theta)
    # over a grid long enough for block padding (n not a square), at non-integer orders
    rng = np.random.default_rng(3)
    x = rng.standard_normal(20011)
    step = 2 * np.pi / 48
    start = 101 * step
    orders = np.array([0.5, 1.0, 5.3569, 23.95])
    theta = start + np.arange(x.size) * step
    direct = np.array([np.sum(x * np.exp(-1j * m * theta)) for m in orders])
    got = uniform_projection(x, start, step, orders)
    assert np.max(np.abs(got - direct)) <= 1e-9 * np.max(np.abs(direct))
