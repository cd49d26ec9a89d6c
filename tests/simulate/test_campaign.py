"""Tests of the closed-loop test campaigns (``gbpipe.simulate.test``).

Physics checks against the references and the config (not against stored numbers):
level ends, LSS = HSS / ratio, reference slopes of tapered ramps, square steps;
reproducibility and the role of each seed; bad input refused before simulating.

Most records use a reduced campaign (8 s holds, 2 s settle) simulated once per module;
the production config is checked with clean-only records (cheap: no harmonics).
"""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np
import pytest
import xarray as xr

import gbpipe.simulate as sim
from gbpipe.config import ConfigError, load, merge, validate
from gbpipe.config.records import highest_excitation_hz
from gbpipe.kinematics import order_of
from tests.conftest import CONFIG

RPM = 2 * np.pi / 60.0  # rad/s per rpm, written out here independently of the library
SMALL = {"campaign": {"hold": 8.0, "settle": 2.0, "sample_rate": 5000.0}}
TESTS = ("speed_up", "speed_down", "torque_up", "torque_down")
PROFILES = ("square", "tapered")
VARIANTS = list(itertools.product(TESTS, PROFILES))
AVG = 0.5  # s averaged at the end of each level
CLEAN = ("motor_torque_driver", "motor_torque_driven", "torque_meter_driving",
         "torque_meter_driven", "speed_gb1_hss", "speed_gb2_hss", "speed_lss")


@pytest.fixture(scope="module")
def cfg_small():
    return load(CONFIG, SMALL)


@pytest.fixture(scope="module")
def records(cfg_small):
    """All 8 reduced variants, measured-like (harmonics, sensor noise, pulses)."""
    return {(t, p): sim.test(cfg_small, t, p) for t, p in VARIANTS}


def _ramp_time(camp, test: str, profile: str) -> float:
    """Ramp time [s] of a step, from the bench rate (full range in ramp_time)."""
    if profile == "square":
        return 0.0
    fr = camp["full_range"]
    if test.startswith("speed"):
        return camp["step"]["speed_rpm"] / (fr["speed_rpm"] / fr["ramp_time"])
    return camp["step"]["torque"] / (fr["torque"] / fr["ramp_time"])


def _levels(camp, test: str, profile: str) -> list[tuple[float, float, float]]:
    """(end time [s], speed ref [rad/s], torque ref [N·m]) of the three levels."""
    ramp = _ramp_time(camp, test, profile)
    settle, hold = camp["settle"], camp["hold"]
    sign = 1.0 if test.endswith("up") else -1.0
    w0, m0 = camp["nominal"]["speed_rpm"] * RPM, camp["nominal"]["torque"]
    if test.startswith("speed"):
        w1, m1 = w0 + sign * camp["step"]["speed_rpm"] * RPM, m0
    else:
        w1, m1 = w0, m0 + sign * camp["step"]["torque"]
    return [(settle, w0, m0), (settle + ramp + hold, w1, m1),
            (settle + 2 * (ramp + hold), w0, m0)]


def _check_level_ends(ds: xr.Dataset, camp) -> dict[str, float]:
    """Assert the level-end physics; return the worst errors."""
    t = ds.time.values
    ratio = ds.attrs["gearbox_ratio"]
    worst = {"speed_rpm": 0.0, "torque_pct": 0.0, "lss_rel": 0.0}
    levels = _levels(camp, ds.attrs["test"], ds.attrs["profile"])
    # the record covers the three levels (to the last whole sample)
    assert t[-1] + (t[1] - t[0]) == pytest.approx(levels[-1][0], abs=1.01 * (t[1] - t[0]))
    for end, w_ref, m_ref in levels:
        win = (t >= end - AVG) & (t < end)
        assert win.sum() == pytest.approx(AVG * ds.attrs["sample_rate"], abs=1)
        # the references are at their level over the whole averaging window
        np.testing.assert_allclose(ds.speed_ref.values[win], w_ref, rtol=1e-12)
        np.testing.assert_allclose(ds.torque_ref.values[win], m_ref, rtol=1e-12)
        for name in ("speed_gb1_hss", "speed_gb2_hss"):
            err = abs(ds[name].values[win].mean() - w_ref) / RPM
            worst["speed_rpm"] = max(worst["speed_rpm"], err)
            assert err < 0.1, f"{name} at t={end:g} s is {err:.3f} rpm off the reference"
        # lossless bench, ratio 1 between the HSSs: every torque settles to the reference
        for name in ("torque_meter_driven", "torque_meter_driving", "motor_torque_driver",
                     "motor_torque_driven"):
            err = 100 * abs(ds[name].values[win].mean() - m_ref) / m_ref
            worst["torque_pct"] = max(worst["torque_pct"], err)
            assert err < 0.5, f"{name} at t={end:g} s is {err:.3f} % off the reference"
        w_hss = ds.speed_gb1_hss.values[win].mean()
        rel = abs(ds.speed_lss.values[win].mean() * ratio / w_hss - 1)
        worst["lss_rel"] = max(worst["lss_rel"], rel)
        assert rel < 1e-4, f"speed_lss x ratio differs from speed_gb1_hss by {rel:.2e}"
    return worst


# --------------------------------------------------------------------- level ends


@pytest.mark.parametrize(("test", "profile"), VARIANTS)
def test_level_ends_reduced(records, cfg_small, test, profile):
    _check_level_ends(records[test, profile], cfg_small["campaign"])


@pytest.mark.parametrize(("test", "profile"), VARIANTS)
def test_level_ends_production_config(cfg, test, profile):
    """The production campaign (5 s settle, 20 s holds), clean signals only."""
    ds = sim.test(cfg, test, profile, measured_like=False)
    assert "torque_meter_driven_measured" not in ds
    _check_level_ends(ds, cfg["campaign"])


def test_measured_like_adds_to_clean_without_changing_it(records, cfg_small):
    """measured_like=False gives the same clean signals (same seed, same noise key)."""
    ds = records["torque_up", "tapered"]
    clean = sim.test(cfg_small, "torque_up", "tapered", measured_like=False)
    for name in CLEAN + ("speed_ref", "torque_ref"):
        np.testing.assert_array_equal(clean[name].values, ds[name].values, err_msg=name)


def test_gearbox_ratio_attribute(records, cfg_small):
    """Ratio from the teeth: planetary 1 + Zr/Zs with fixed ring, parallel Zw/Zp."""
    ratio = Fraction(1)
    for st in cfg_small["gearbox"]["stages"]:
        if st["type"] == "planetary":
            ratio *= 1 + Fraction(st["ring"], st["sun"])
        else:
            ratio *= Fraction(st["wheel"], st["pinion"])
    for ds in records.values():
        assert ds.attrs["gearbox_ratio"] == pytest.approx(float(ratio), rel=1e-12)


# ------------------------------------------------------------- reference profiles


@pytest.mark.parametrize(("test", "profile"), VARIANTS)
def test_reference_profiles(records, cfg_small, test, profile):
    ds = records[test, profile]
    camp = cfg_small["campaign"]
    fs = camp["sample_rate"]
    t = ds.time.values
    np.testing.assert_allclose(np.diff(t), 1 / fs, rtol=1e-9)
    stepped, held = ("speed_ref", "torque_ref") if test.startswith("speed") else (
        "torque_ref", "speed_ref")
    nominal = (camp["nominal"]["speed_rpm"] * RPM if stepped == "speed_ref"
               else camp["nominal"]["torque"])
    step = camp["step"]["speed_rpm"] * RPM if stepped == "speed_ref" else camp["step"]["torque"]
    sign = 1.0 if test.endswith("up") else -1.0
    ref = ds[stepped].values
    # the other reference is held at nominal throughout
    other = (camp["nominal"]["torque"] if held == "torque_ref"
             else camp["nominal"]["speed_rpm"] * RPM)
    np.testing.assert_allclose(ds[held].values, other, rtol=1e-12)
    assert ref.min() == pytest.approx(min(nominal, nominal + sign * step), rel=1e-12)
    assert ref.max() == pytest.approx(max(nominal, nominal + sign * step), rel=1e-12)
    d = np.diff(ref)
    moving = np.flatnonzero(np.abs(d) > 1e-9 * nominal)
    settle, hold = camp["settle"], camp["hold"]
    if profile == "square":
        # exactly two one-sample jumps of the full step, out at `settle`, back after `hold`
        assert moving.size == 2
        np.testing.assert_allclose(d[moving], [sign * step, -sign * step], rtol=1e-12)
        np.testing.assert_allclose(t[moving + 1], [settle, settle + hold], atol=1.01 / fs)
        return
    # tapered: 1980 rpm / 90 s = 22 rpm/s, 40 kN·m / 90 s = 444.4 N·m/s
    slope = 22.0 * RPM if stepped == "speed_ref" else 40000.0 / 90.0
    ramp = step / slope
    assert ramp == pytest.approx(2.2727 if stepped == "speed_ref" else 11.25, abs=1e-4)
    seg = np.split(moving, np.flatnonzero(np.diff(moving) > 1) + 1)
    assert len(seg) == 2, "a tapered test has one ramp out and one ramp back"
    for k, (idx, s) in enumerate(zip(seg, (sign, -sign), strict=True)):
        # interior samples (both ends of the ramp fall between samples)
        inner = idx[1:-1]
        np.testing.assert_allclose(d[inner] * fs, s * slope, rtol=1e-6)
        fit = np.polyfit(t[inner], ref[inner], 1)[0]
        assert fit == pytest.approx(s * slope, rel=1e-9)
        # ramp length from the first to the last moving sample
        assert (idx[-1] - idx[0] + 1) / fs == pytest.approx(ramp, abs=2 / fs)
        start = settle + k * (ramp + hold)
        assert t[idx[0]] == pytest.approx(start, abs=1 / fs)


def test_square_step_sample_at_step_instant_takes_new_level(records, cfg_small):
    """ZOH convention documented in profiles.step_reference: u[k] holds over
    [k dt, (k+1) dt), so the sample at t = settle is the first at the new level and the
    sample at t = settle + hold the first back at nominal."""
    camp = cfg_small["campaign"]
    fs = camp["sample_rate"]
    k0 = int(round(camp["settle"] * fs))
    k1 = int(round((camp["settle"] + camp["hold"]) * fs))
    late = []
    for test in TESTS:
        ds = records[test, "square"]
        assert ds.time.values[k0] == camp["settle"]
        ref = ds.speed_ref.values if test.startswith("speed") else ds.torque_ref.values
        if ref[k0] == ref[k0 - 1]:
            late.append(f"{test} step out")
        if ref[k1] == ref[k1 - 1]:
            late.append(f"{test} step back")
    assert not late, f"square steps one sample late: {late}"


def test_tapered_torque_follows_ramp_rate(records):
    """The driven-side torque meter follows an 11.25 s torque ramp at its slope (±2 %)."""
    for test in ("torque_up", "torque_down"):
        ds = records[test, "tapered"]
        t = ds.time.values
        ramp_mid = (t > 2.0 + 0.3 * 11.25) & (t < 2.0 + 0.7 * 11.25)
        sign = 1.0 if test.endswith("up") else -1.0
        fit = np.polyfit(t[ramp_mid], ds.torque_meter_driven.values[ramp_mid], 1)[0]
        assert fit == pytest.approx(sign * 40000.0 / 90.0, rel=0.02)


# ----------------------------------------------------------------- reproducibility


def _small_seed(seed: int, **extra):
    return load(CONFIG, SMALL, {"seed": seed}, extra)


def _line(ds: xr.Dataset, name: str, order: float, t0: float, t1: float) -> complex:
    """Complex amplitude of the harmonic part (measured − clean) at order × HSS speed.

    Hann-windowed DFT of one window at the frequency from the speed *reference*, so it
    is independent of each record's own angle.
    """
    t = ds.time.values
    win = (t >= t0) & (t < t1)
    h = (ds[f"{name}_measured"] - ds[name]).values[win]
    f = order * ds.speed_ref.values[win].mean() / (2 * np.pi)
    w = np.hanning(h.size)
    return 2 * np.sum(w * h * np.exp(-2j * np.pi * f * t[win])) / w.sum()


def test_same_config_and_seed_identical(records, cfg_small):
    again = sim.test(load(CONFIG, SMALL), "speed_up", "square")
    xr.testing.assert_identical(again, records["speed_up", "square"])


def test_other_seed_changes_only_the_noise(records, cfg_small):
    a = records["speed_up", "square"]
    b = sim.test(_small_seed(cfg_small["seed"] + 1), "speed_up", "square")
    # noise-free parts: identical
    for name in ("time", "speed_ref", "torque_ref", "tooth_spacing_error"):
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
    assert a.pulse.size == b.pulse.size
    # the clean signals contain motor ripple (process noise): they differ ...
    for name in CLEAN:
        assert not np.array_equal(a[name].values, b[name].values), name
    # ... but not in their physics: both meet the level-end checks
    _check_level_ends(b, cfg_small["campaign"])
    # the harmonics keep their phase (from excitation.seed): the 3x and mesh-2 lines in
    # measured − clean are the same complex amplitude to within 3 %
    o_mesh2 = float(order_of(cfg_small["gearbox"]["stages"], "mesh2"))
    for name in ("torque_meter_driven", "torque_meter_driving"):
        for order in (3.0, o_mesh2):
            for t0 in (0.5, 6.0, 15.0):  # nominal, stepped level, back at nominal
                za, zb = _line(a, name, order, t0, t0 + 1.0), _line(b, name, order, t0, t0 + 1.0)
                # a 1 s Hann DFT of 10 N·m rms sensor noise at 5 kHz is ~0.35 N·m
                assert abs(za) > 50.0
                assert abs(zb / za - 1) < 0.03, (name, order, t0, zb / za)


def test_without_noise_seed_changes_nothing(cfg_small):
    """Noise switched off: two seeds give identical signals (the seed only draws noise)."""
    still = {"broadband": 0.0, "pulsating": []}
    quiet = {"noise": {"motor_ripple": {"driver": still, "driven": still},
                       "sensor": {"speed": 0.0, "torque": 0.0}},
             "tachometer": {"jitter": 0.0}}
    a = sim.test(_small_seed(1, **quiet), "torque_down", "square")
    b = sim.test(_small_seed(2, **quiet), "torque_down", "square")
    assert a.attrs["seed"] != b.attrs["seed"]
    xr.testing.assert_equal(a, b)


def test_excitation_seed_changes_only_the_harmonics(records, cfg_small):
    a = records["speed_up", "square"]
    b = sim.test(load(CONFIG, SMALL, {"excitation": {"seed": 8}}), "speed_up", "square")
    for name in CLEAN + ("speed_ref", "torque_ref"):
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
    za = _line(a, "torque_meter_driven", 3.0, 0.5, 1.5)
    zb = _line(b, "torque_meter_driven", 3.0, 0.5, 1.5)
    # same amplitude (config), another phase (drawn from excitation.seed)
    assert abs(zb) == pytest.approx(abs(za), rel=0.03)
    assert abs(np.angle(zb / za)) > 0.05


# ---------------------------------------------------------------------- bad input


@pytest.mark.parametrize(("test", "profile", "message"), [
    ("speed_sideways", "square", r"^test: unknown test 'speed_sideways'.*speed_up"),
    ("torque_up", "sinusoidal", r"^profile: unknown profile 'sinusoidal'.*tapered"),
])
def test_unknown_test_or_profile(cfg_small, no_simulation, test, profile, message):
    with pytest.raises(ValueError, match=message):
        sim.test(cfg_small, test, profile)


@pytest.mark.parametrize(("overlay", "field"), [
    ({"hold": 0.0}, "campaign.hold"),          # a record too short for its steps
    ({"hold": -3.0}, "campaign.hold"),         # negative duration
    ({"settle": -1.0}, "campaign.settle"),     # negative duration
    ({"sample_rate": 2000.0}, "campaign.sample_rate"),
])
def test_bad_campaign_refused_before_simulating(cfg_small, no_simulation, overlay, field):
    bad = merge(cfg_small, {"campaign": overlay})
    # refused at load (docs/architecture.md, "Data contract"): test() takes valid configs
    with pytest.raises(ConfigError, match=rf"'{field}'"):
        validate(bad, check_stability=False)


def test_sample_rate_limit_is_2p5_times_highest_excitation(cfg_small, no_simulation):
    """The limit sits at 2.5 × the highest excitation frequency, computed from the teeth."""
    f_max = highest_excitation_hz(cfg_small, 1170.0)  # top campaign speed [rpm]
    assert f_max == pytest.approx(29 * 2 * 1170 / 60)  # stage-3 mesh (29x), 2nd harmonic
    ok_rate = 2.5 * f_max * 1.01  # identify.sample_rate must divide it by an integer
    ok = merge(cfg_small, {"campaign": {"sample_rate": ok_rate},
                           "identify": {"sample_rate": ok_rate / 2}})
    validate(ok, check_stability=False)
    low = merge(cfg_small, {"campaign": {"sample_rate": 2.5 * f_max * 0.99}})
    with pytest.raises(ConfigError, match=r"'campaign\.sample_rate'.*2\.5"):
        validate(low, check_stability=False)


def test_missing_campaign_section(cfg_small, no_simulation):
    bad = {k: v for k, v in cfg_small.items() if k != "campaign"}
    with pytest.raises(ValueError, match="campaign"):
        sim.test(bad, "speed_up", "square")
