"""Tests of the second line-carrying shaft's angle (gbpipe.harmonics.shaft_angles) and of
the regression that fits the lines of both shafts (``twist``).

The record: a speed ramp of the tachometer's shaft, a second shaft whose angle leads it by
a twist that moves by 40 mrad within 0.3 s (the speed loop's transient when a ramp starts,
docs/removal.md), lines locked to each shaft, white noise. Closed forms: the twist of a
sinusoidal speed difference, and an exact harmonic model once both angles are known.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from gbpipe.errors import ConfigError, DataError
from gbpipe.harmonics import record_params, residual_regression, shaft_twist

FS = 2000.0  # Hz
T_END = 16.0  # s
F0, RATE = 10.0, 0.5  # tachometer shaft rate at t = 0 [rev/s], its slope [rev/s^2]
STEP, T_STEP, WIDTH = 0.04, 6.0, 0.1  # twist change [rad], its time and time scale [s]


def _twist(t: np.ndarray) -> np.ndarray:
    return 0.01 + 0.5 * STEP * (1 + np.tanh((t - T_STEP) / WIDTH))


def _record(seed: int) -> dict:
    t = np.arange(int(T_END * FS)) / FS
    theta = 2 * np.pi * (F0 * t + 0.5 * RATE * t**2)
    tw = _twist(t)
    rng = np.random.default_rng(seed)
    # order 3 (slow phase change 0.12 rad: below no threshold) and 29 (1.2 rad) on both
    h = np.zeros_like(t)
    for o, a1, a2 in ((3.0, 1.0, 0.7), (29.0, 0.5, 0.4)):
        h += a1 * np.cos(o * theta + rng.uniform(0, 2 * np.pi))
        h += a2 * np.cos(o * (theta + tw) + rng.uniform(0, 2 * np.pi))
    k = np.arange(1, int(theta[-1] / (2 * np.pi)) + 1)
    pulses = (-F0 + np.sqrt(F0**2 + 2 * RATE * k)) / RATE  # theta(t) = 2 pi k
    w1 = 2 * np.pi * (F0 + RATE * t)
    dtw = 0.5 * STEP / WIDTH / np.cosh((t - T_STEP) / WIDTH) ** 2  # d twist / dt
    noise = 2e-3  # rad/s rms speed noise of each channel
    return {"t": t, "h": h, "n": 0.01 * rng.standard_normal(t.size), "pulses": pulses,
            "w1": w1 + noise * rng.standard_normal(t.size),
            "w2": w1 + dtw + noise * rng.standard_normal(t.size), "twist": tw}


@pytest.fixture(scope="module")
def rec():
    return _record(1)


def test_twist_of_a_sinusoidal_speed_difference_is_its_integral():
    t = np.arange(20000) / 1e4
    w1 = 100.0 + 30.0 * t
    c, f = 0.5, 3.0  # rad/s, Hz
    tw = shaft_twist(w1, 2.0 * (w1 + c * np.sin(2 * np.pi * f * t)), 1e4, ratio=2.0)
    exact = c / (2 * np.pi * f) * (1 - np.cos(2 * np.pi * f * t))
    assert np.max(np.abs(tw - exact)) < 1e-6 * c / (2 * np.pi * f) * 100


def test_twist_from_noisy_speeds_follows_the_true_twist(rec):
    tw = shaft_twist(rec["w1"], rec["w2"], FS)
    err = tw - (rec["twist"] - rec["twist"][0])
    # a random walk of the 2e-3 rad/s noise: sqrt(2) 2e-3 / FS sqrt(n) ~ 1.3e-4 rad rms
    assert np.abs(err).max() < 1e-3
    assert np.ptp(tw) == pytest.approx(STEP, rel=0.03)


def test_second_angle_removes_the_lines_of_both_shafts(rec):
    """Exact model once both angles are known (the cubic angle through the pulses is exact
    for a ramp): the harmonic part alone is removed to far below what the tachometer
    angle alone leaves, about ``order x`` the twist's unfollowed change (order 29: 0.3
    rad)."""
    tw = shaft_twist(rec["w1"], rec["w2"], FS)
    kw = dict(knot_spacing=2.0, method="cubic")
    span = slice(int(0.2 * FS), -int(0.2 * FS))  # inside the pulses (no angle outside)
    p = np.mean(rec["h"][span] ** 2)
    one = residual_regression(rec["h"], FS, rec["pulses"], {"a": [3.0, 29.0]}, **kw)
    # twist_phase small: both orders on both angles
    two = residual_regression(rec["h"], FS, rec["pulses"], {"a": [3.0, 29.0]}, twist=tw,
                              twist_phase=1e-3, **kw)
    left_one = 10 * np.log10(p / np.mean(one[span] ** 2))
    left_two = 10 * np.log10(p / np.mean(two[span] ** 2))
    assert left_one < 30.0  # the order-29 line of the second shaft, unfollowed
    assert left_two > 60.0  # limited by the speed noise's random walk in the twist
    # with the random part: the residual is the random part to within a fraction of it
    r = residual_regression(rec["h"] + rec["n"], FS, rec["pulses"], {"a": [3.0, 29.0]},
                            twist=tw, twist_phase=1e-3, **kw)
    assert np.mean((r - rec["n"])[span] ** 2) < 0.05 * np.mean(rec["n"][span] ** 2)


def test_orders_the_envelope_follows_keep_one_line(rec):
    """An order whose phase the twist moves less than twist_phase beyond its envelope
    keeps its single line: the fit is that of the tachometer angle alone."""
    tw = shaft_twist(rec["w1"], rec["w2"], FS)
    x = rec["h"] + rec["n"]
    fam = {"a": [3.0]}
    base = residual_regression(x, FS, rec["pulses"], fam, knot_spacing=2.0)
    same = residual_regression(x, FS, rec["pulses"], fam, knot_spacing=2.0, twist=tw,
                               twist_phase=10.0)
    np.testing.assert_allclose(same, base, rtol=0, atol=1e-12 * np.abs(x).max())
    other = residual_regression(x, FS, rec["pulses"], fam, knot_spacing=2.0, twist=tw,
                                twist_families=["b"], twist_phase=1e-6)
    np.testing.assert_allclose(other, base, rtol=0, atol=1e-12 * np.abs(x).max())


def test_bad_twist_and_speeds_are_refused(rec):
    with pytest.raises(DataError, match="twist"):
        residual_regression(rec["h"], FS, rec["pulses"], {"a": [3.0]}, twist=rec["t"][:-5])
    with pytest.raises(DataError, match="speed_other"):
        shaft_twist(rec["w1"], rec["w2"][:-1], FS)
    bad = rec["w2"].copy()
    bad[7] = np.nan
    with pytest.raises(DataError, match="speed_other"):
        shaft_twist(rec["w1"], bad, FS)


def test_record_params_take_the_twist_from_the_record_speeds(rec):
    ds = xr.Dataset({"speed_gb1_hss_measured": ("time", rec["w1"]),
                     "speed_gb2_hss_measured": ("time", rec["w2"])},
                    attrs={"sample_rate": FS})
    p = record_params({"knot_spacing": 2.0,
                       "second_angle": ["speed_gb1_hss", "speed_gb2_hss"]}, ds)
    assert "second_angle" not in p
    np.testing.assert_allclose(p["twist"], np.cumsum(np.r_[0.0, 0.5 * (
        rec["w2"] - rec["w1"])[1:] + 0.5 * (rec["w2"] - rec["w1"])[:-1]]) / FS, atol=1e-12)
    assert "twist" not in record_params({"second_angle": []}, ds)
    with pytest.raises(ConfigError, match="second_angle"):
        record_params({"second_angle": ["speed_gb1_hss", "speed_lss"]}, ds)
