"""Harmonic-removal stage: which families a cycle removes (exact), and removal on
bench-simulated sweeps (the ~62 Hz resonance, shaft orders and mesh harmonics)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import xarray as xr
from scipy.signal import savgol_coeffs

from gbpipe import harmonics
from gbpipe.config import load, merge, validate
from gbpipe.harmonics import residual
from gbpipe.simulate import sweep
from tests.conftest import CI_CONFIG, CONFIG


@pytest.fixture(scope="module")
def ci_cfg():
    return load(CONFIG, CI_CONFIG)


def test_removed_families_are_exact_multiples(ci_cfg):
    stages = ci_cfg["gearbox"]["stages"]
    fams = harmonics.excitation_families(ci_cfg)
    assert fams["shaft"] == [1, 2, 3]
    assert fams["mesh2"][0] == Fraction(3857, 720)
    hss = harmonics.removed_families(fams, harmonics.cycle_orders(stages, ["hss"]))
    # the HSS cycle takes the shaft orders, the stage-3 mesh (29 teeth on the HSS pinion:
    # integer orders 29, 58) and the converters' pulsating torque (harmonics 6 and 12 of
    # 2 pole pairs: HSS orders 12, 24), never the planetary meshes
    assert set(hss) == {"shaft", "mesh3", "motor"} and hss["mesh3"] == [29, 58]
    assert hss["motor"] == [12, 24]
    car = harmonics.removed_families(fams, harmonics.cycle_orders(stages, ["carrier2"]))
    assert set(car) == {"mesh2"}            # mesh 2 is the 114th carrier-2 order
    assert harmonics.removed_families(fams, harmonics.cycle_orders(stages, ["mesh2"])) == {
        "mesh2": fams["mesh2"]}


def test_sliding_average_cancels_linear_amplitude_drift():
    """A harmonic whose amplitude drifts linearly: block averages leave the drift inside
    each block, the centred sliding average cancels it."""
    fs, f_rot, T = 4000.0, 20.0, 30.0
    t = np.arange(int(T * fs)) / fs
    pulses = np.arange(1, int(T * f_rot)) / f_rot
    amp = 1.0 + 2.0 * t / T
    x = amp * np.sin(2 * np.pi * 0.5 * f_rot * t)      # order 0.5: cycle = 2 revolutions
    # power left, away from the ends where the centred window is clipped (20 cycles)
    inner = (t > 2.0) & (t < T - 2.0)
    att = {}
    for av in ("block", "sliding"):
        r = residual(x, fs, pulses, Fraction(1, 2), 10, averaging=av)
        att[av] = 10 * np.log10(np.mean(x[inner] ** 2) / np.mean(r[inner] ** 2))
    # block: the drift within each 1 s block stays (a sawtooth of about ±3 % of the
    # amplitude, near -40 dB); the centred average cancels a linear drift exactly
    assert att["block"] < 45.0
    assert att["sliding"] > att["block"] + 10.0


@pytest.fixture(scope="module")
def sweep_fast(ci_cfg):
    """The CI sweep: 400 -> 1120 rpm in 36 s, 5 kHz, bench-simulated."""
    return sweep(ci_cfg)


def _run(cfg, sw, cycles, modes=(61.9,)):
    x = sw.torque_meter_driven_measured.values.astype(float)
    fs, p = float(sw.attrs["sample_rate"]), sw.pulse_time.values
    cyc = harmonics.cycle_orders(cfg["gearbox"]["stages"], cycles)
    fams = harmonics.removed_families(harmonics.excitation_families(cfg), cyc)
    r = harmonics.remove(x, fs, p, cyc, cfg["tsa"])
    return harmonics.variant_metrics(x, r, fs, p, fams, list(modes), cfg["spectra"])


@pytest.mark.parametrize(("variant", "family"), [("hss", "shaft"), ("mesh2", "mesh2")])
def test_variant_removes_its_family_on_the_sweep(ci_cfg, sweep_fast, variant, family):
    m = _run(ci_cfg, sweep_fast, [variant])
    assert float(m.attenuation.sel(family=family)) >= 40.0
    # the bench resonance near 62 Hz is not removed with the harmonics
    assert abs(float(m.mode_change.isel(mode=0))) < 1.0


def test_joint_removal_beats_cascade_and_removes_both(ci_cfg, sweep_fast):
    """The cascade is HSS TSA then mesh-2 TSA on its residual; the joint removal iterates
    it, so it must remove both families at least as well, and better where each family's
    average caught part of the other (the cascade never restores that part)."""
    x = sweep_fast.torque_meter_driven_measured.values.astype(float)
    fs, p = float(sweep_fast.attrs["sample_rate"]), sweep_fast.pulse_time.values
    tsa_cfg = ci_cfg["tsa"]
    cyc = harmonics.cycle_orders(ci_cfg["gearbox"]["stages"], ["hss", "mesh2"])
    # the cascade is the two single-family removals in turn (independent computation)
    cascade = harmonics.remove(x, fs, p, cyc, tsa_cfg, mode="cascade")
    n = tsa_cfg["n_cycles"]
    by_hand = residual(residual(x, fs, p, cyc[0], n), fs, p, cyc[1], n)
    np.testing.assert_allclose(cascade, by_hand, rtol=0, atol=1e-9 * np.max(np.abs(x)))
    # the stage computes both removals and their metrics on the same bins
    variant = dict(tsa_cfg, cycles=["hss", "mesh2"])
    bench = xr.Dataset({"closed_mode_frequency": ("mode", [61.9])})
    ds = harmonics.tsa_variant(sweep_fast, bench, "joint", variant, ci_cfg["spectra"],
                               ci_cfg["gearbox"]["stages"], ci_cfg["excitation"])
    for fam in ("shaft", "mesh2"):
        joint, casc = (float(ds[v].sel(family=fam))
                       for v in ("attenuation", "cascade_attenuation"))
        assert joint >= 35.0
        assert joint > casc + 1.0, (fam, joint, casc)
    # the residual written is the joint one, not the cascade
    assert not np.allclose(ds.residual.values, cascade)


def test_carrier2_removes_mesh2_when_speed_is_steady(ci_cfg):
    """Carrier-2 cycles are long (21 HSS revolutions): on a near-steady run they remove the
    stage-2 mesh family like the mesh-synchronous variant does."""
    cfg = validate(merge(ci_cfg, {"sweep": {"rpm_start": 1100.0, "rpm_end": 1120.0,
                                            "duration": 40.0, "settle": 1.0,
                                            "sample_rate": 4000.0}}))
    m = _run(cfg, sweep(cfg), ["carrier2"])
    assert float(m.attenuation.sel(family="mesh2")) >= 40.0


def test_structural_modes_merge_twin_pairs():
    f = harmonics.structural_modes([1.0, 27.3, 61.9, 62.4, 125.6, 130.4, 338.8, 338.8],
                                   10.0, 400.0, 4.0)
    np.testing.assert_allclose(f, [27.3, 62.15, 125.6, 130.4, 338.8])


def test_quadratic_average_removes_carrier2_family_on_the_sweep(ci_cfg):
    """Carrier-2 blocks of 10 revolutions span up to 180 rpm of the full config's sweep
    (400 -> 1120 rpm in 120 s); fitting a quadratic across cycles follows the harmonic's
    amplitude and phase through the resonance where the block mean cannot."""
    cfg = validate(merge(ci_cfg, {"sweep": {"duration": 120.0, "sample_rate": 4000.0}}))
    sw = sweep(cfg)
    m_block = _run(cfg, sw, ["carrier2"])
    m_quad = _run(validate(merge(cfg, {"tsa": {"averaging": "quadratic"}})), sw, ["carrier2"])
    assert float(m_quad.attenuation.sel(family="mesh2")) >= 40.0
    assert float(m_quad.attenuation.sel(family="mesh2")) > float(
        m_block.attenuation.sel(family="mesh2")) + 10.0


def test_quadratic_average_noise_loss_is_its_centre_weight():
    """White noise keeps (1 - c0) of its power, c0 the Savitzky-Golay centre weight
    (0.2075 for 11 cycles: -1.02 dB); unbiased=True restores it."""
    rng = np.random.default_rng(5)
    fs, f_rot, T = 2000.0, 25.0, 40.0
    x = rng.standard_normal(int(T * fs))
    pulses = np.arange(1, int(T * f_rot)) / f_rot
    c0 = savgol_coeffs(11, 2)[5]
    inner = slice(int(2 * fs), int((T - 2) * fs))
    for unbiased, expected in ((False, 1 - c0), (True, 1.0)):
        r = residual(x, fs, pulses, 1, 10, averaging="quadratic", unbiased=unbiased)
        ratio = np.mean(r[inner] ** 2) / np.mean(x[inner] ** 2)
        assert ratio == pytest.approx(expected, rel=0.03)


def test_record_residuals_remove_a_locked_harmonic_and_keep_the_step(ci_cfg):
    """Constant-speed HSS at 18 Hz, a 3rd-order harmonic and a torque step: the TSA of the
    removal_tests stage (hss + mesh2 removed) must take the harmonic and keep the step, which
    lies below the split frequency and is added back untouched."""
    fs, duration, f0 = 2000.0, 12.0, 18.0
    t = np.arange(int(duration * fs)) / fs
    theta = 2 * np.pi * f0 * t
    step = np.where((t > 4) & (t < 8), 100.0, 0.0)
    harm = 50.0 * np.sin(3 * theta + 0.3)
    pulses = np.arange(1, int(duration * f0) - 1) / f0
    rec = xr.Dataset({"x_measured": ("time", step + harm, {"units": "N m"}),
                      "speed_gb1_hss": ("time", np.full(t.size, 2 * np.pi * f0)),
                      "pulse_time": ("pulse", pulses)}, coords={"time": t},
                     attrs={"sample_rate": fs, "pulses_per_rev": 1, "test": "speed_up",
                            "profile": "square"})
    tsa_cfg = dict(ci_cfg["tsa"], tests=["hss", "mesh2"])
    ds = harmonics.record_residuals(rec, ["x"], ci_cfg["gearbox"]["stages"], tsa_cfg, 0.5)
    r = ds.x.values
    inner = (t > 1) & (t < duration - 1) & (np.abs(t - 4) > 0.3) & (np.abs(t - 8) > 0.3)
    assert np.std((r - step)[inner]) < 0.05 * np.std(harm)
    assert ds.x.attrs["units"] == "N m"
    assert ds.attrs["removed_cycles"] == "hss,mesh2" and ds.attrs["test"] == "speed_up"
    # nothing to remove: the signals come back unchanged
    same = harmonics.record_residuals(rec, ["x"], ci_cfg["gearbox"]["stages"],
                                      dict(tsa_cfg, tests=[]), 0.5)
    np.testing.assert_array_equal(same.x.values, rec.x_measured.values)
