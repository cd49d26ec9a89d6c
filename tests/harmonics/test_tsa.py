"""Tests of gbpipe.harmonics.tsa on synthetic sweeps independent of any bench model
(:mod:`harmonic_sweeps`): removal judged by projection on the exact sinusoids."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from harmonic_sweeps import CARRIER, FS, HSS_ORDERS, MESH, MESH_ORDERS, db, line_power, make_sweep

from gbpipe.errors import DataError, PulseError
from gbpipe.harmonics import joint, tsa


# --------------------------------------------------------------------------- removal
@pytest.mark.parametrize("name, order, own, other", [
    ("hss", 1, HSS_ORDERS, MESH_ORDERS),
    ("mesh2", MESH, MESH_ORDERS, HSS_ORDERS),
    ("carrier2", MESH / 114, MESH_ORDERS, HSS_ORDERS),
])
def test_each_variant_removes_its_family(sw, name, order, own, other):
    r, info = tsa.residual(sw["x"], FS, sw["pulses"], order, return_info=True)
    m = info.valid
    att_own = db(line_power(sw["x"], sw["theta"], own, m) / line_power(r, sw["theta"], own, m))
    att_other = db(line_power(sw["x"], sw["theta"], other, m)
                   / line_power(r, sw["theta"], other, m))
    assert att_own >= 40.0, f"{name}: own family only {att_own:.1f} dB down"
    assert abs(att_other) < 1.0, f"{name}: other family changed by {att_other:.2f} dB"


@pytest.mark.parametrize("order", [1, MESH, MESH / 114])
def test_family_alone_is_removed_including_sidebands(clean, order):
    # Noise-free family only: the whole residual is leftover, sidebands included.
    x = clean["mesh"] if order != 1 else clean["hss"]
    r, info = tsa.residual(x, FS, clean["pulses"], order, return_info=True)
    m = info.valid
    assert db(np.mean(x[m] ** 2) / np.mean(r[m] ** 2)) >= 60.0


def test_fraction_cycle_order_matches_float(clean):
    r_frac = tsa.residual(clean["mesh"], FS, clean["pulses"], CARRIER)
    r_float = tsa.residual(clean["mesh"], FS, clean["pulses"], float(CARRIER))
    np.testing.assert_allclose(r_frac, r_float, atol=1e-12)
    # The mesh is the carrier's 114th-and-a-bit harmonic: 114 * 609/12960 = 5.3569...
    assert abs(114 * float(CARRIER) - MESH) < 1e-4


def test_pchip_beats_linear_angle_interpolation(clean):
    x = clean["mesh"]
    out = {}
    for method in ("pchip", "linear"):
        r, info = tsa.residual(x, FS, clean["pulses"], MESH, method=method, return_info=True)
        out[method] = db(np.mean(x[info.valid] ** 2) / np.mean(r[info.valid] ** 2))
    assert out["pchip"] > 70.0
    assert out["pchip"] > out["linear"] + 20.0


def test_pulses_per_rev_equivalent(clean):
    sw4 = make_sweep(noise=0.0, pulses_per_rev=4)
    r1, i1 = tsa.residual(clean["mesh"], FS, clean["pulses"], MESH, return_info=True)
    # Four pulses per rev, first pulse at a quarter turn: same cycles shifted in phase;
    # judge each by its own removal.
    r4, i4 = tsa.residual(sw4["mesh"], FS, sw4["pulses"], MESH, pulses_per_rev=4,
                          return_info=True)
    for r, info in ((r1, i1), (r4, i4)):
        m = info.valid
        assert db(np.mean(clean["mesh"][m] ** 2) / np.mean(r[m] ** 2)) > 60.0


def test_tail_cycles_are_removed(clean):
    # K complete cycles is not a multiple of N: the leftover cycles use the last N.
    r, info = tsa.residual(clean["hss"], FS, clean["pulses"], 1, n_cycles=11,
                           return_info=True)
    assert info.n_complete_cycles % 11 != 0
    assert info.n_blocks == -(-info.n_complete_cycles // 11)
    last = np.flatnonzero(info.valid)[-int(2 * FS):]  # last 2 s of the pulse span
    assert db(np.mean(clean["hss"][last] ** 2) / np.mean(r[last] ** 2)) > 40.0


# --------------------------------------------------------------------------- cascade / joint
def test_joint_removes_both_families_where_cascade_does_not(clean):
    x = clean["hss"] + clean["mesh"]
    p = clean["pulses"]
    results = {}
    for mode in ("cascade", "joint"):
        r, info = joint.residual_joint(x, FS, p, [1, Fraction(MESH).limit_denominator(10**6)],
                                     mode=mode, return_info=True)
        m = info.valid
        # Noise-free: everything left is leftover of the two families.
        left = np.mean(r[m] ** 2)
        results[mode] = (db(np.mean(clean["hss"][m] ** 2) / left),
                         db(np.mean(clean["mesh"][m] ** 2) / left))
    assert min(results["joint"]) >= 35.0, results
    assert min(results["cascade"]) < 30.0, results  # about -20 dB, as the theory says


def test_joint_converges_and_reports(clean):
    x = clean["hss"] + clean["mesh"]
    r, info = joint.residual_joint(x, FS, clean["pulses"], [1, MESH], return_info=True)
    assert info.converged and 1 < info.iterations <= 50
    np.testing.assert_allclose(x - info.synchronous[0] - info.synchronous[1], r, atol=1e-9)
    assert info.history[-1] < 3e-3


def test_joint_sliding_that_does_not_contract_stops_at_its_best_pass(clean, monkeypatch):
    # A sliding average is no projection: on HSS + mesh with 4-cycle blocks and the
    # carrier cycle, backfitting contracts for 4 passes and then grows. The pass of
    # smallest change is returned, with a warning, and equals a run stopped there.
    x = clean["hss"] + clean["mesh"]
    args = (x, FS, clean["pulses"], [1, CARRIER])
    kw = dict(n_cycles=4, averaging="sliding", return_info=True)
    with pytest.warns(UserWarning, match="do not contract"):
        r, info = joint.residual_joint(*args, max_iter=50, **kw)
    h = np.asarray(info.history)
    best = int(np.argmin(h[1:])) + 2  # passes are counted from 1; pass 1 is the cascade
    assert info.iterations == best and not info.converged
    assert np.all(np.diff(h[best - 1:]) > 0) and len(h) == best + 3  # three growing passes
    with pytest.warns(UserWarning, match="not converged"):
        r_at = joint.residual_joint(*args, max_iter=best, **kw)[0]
    np.testing.assert_array_equal(r, r_at)
    # left to run on, it diverges: by pass 50 a pass changes the residual by more than
    # the whole signal (and the pass of smallest change is still what comes back)
    monkeypatch.setattr(joint, "_GROWTH_PASSES", 10**6)
    with pytest.warns(UserWarning, match="do not contract"):
        r_on, info_on = joint.residual_joint(*args, max_iter=50, **kw)
    assert info_on.history[-1] > 1.0 and len(info_on.history) == 50
    np.testing.assert_array_equal(r_on, r)


# --------------------------------------------------------------------------- noise loss
@pytest.mark.parametrize("n_cycles", [10, 5])
@pytest.mark.parametrize("order", [1, MESH])
def test_white_noise_loses_one_over_n(clean, order, n_cycles):
    w = np.random.default_rng(3).standard_normal(clean["t"].size)
    r, info = tsa.residual(w, FS, clean["pulses"], order, n_cycles=n_cycles, return_info=True)
    m = info.valid
    loss = db(np.mean(r[m] ** 2) / np.mean(w[m] ** 2))
    assert loss == pytest.approx(db(1 - 1 / n_cycles), abs=0.06)  # -0.46 dB at N = 10
    ru = tsa.residual(w, FS, clean["pulses"], order, n_cycles=n_cycles, unbiased=True)
    assert db(np.mean(ru[m] ** 2) / np.mean(w[m] ** 2)) == pytest.approx(0.0, abs=0.06)


def test_joint_white_noise_loss_and_unbiased(clean):
    w = np.random.default_rng(4).standard_normal(clean["t"].size)
    r, info = joint.residual_joint(w, FS, clean["pulses"], [1, MESH], return_info=True)
    m = info.valid
    assert db(np.mean(r[m] ** 2) / np.mean(w[m] ** 2)) == pytest.approx(db(1 - 2 / 10),
                                                                       abs=0.1)
    ru = joint.residual_joint(w, FS, clean["pulses"], [1, MESH], unbiased=True)
    assert db(np.mean(ru[m] ** 2) / np.mean(w[m] ** 2)) == pytest.approx(0.0, abs=0.1)


# --------------------------------------------------------------------------- contract
def test_shape_edges_and_input_untouched(sw):
    x = sw["x"].copy()
    p = sw["pulses"]
    r, info = tsa.residual(x, FS, p, 1, outside="nan", return_info=True)
    np.testing.assert_array_equal(x, sw["x"])
    assert r.shape == x.shape
    t = sw["t"]
    inside = (t >= p[0]) & (t <= p[-1])
    np.testing.assert_array_equal(info.valid, inside)
    assert np.all(np.isnan(r[~inside])) and np.all(np.isfinite(r[inside]))
    r_keep = tsa.residual(x, FS, p, 1)
    np.testing.assert_array_equal(r_keep[~inside], x[~inside])
    np.testing.assert_allclose(r_keep[inside], r[inside])


def test_t0_shifts_time_axis(clean):
    r0 = tsa.residual(clean["hss"], FS, clean["pulses"], 1)
    r5 = tsa.residual(clean["hss"], FS, clean["pulses"] + 5.0, 1, t0=5.0)
    np.testing.assert_allclose(r0, r5, atol=1e-9)


# --------------------------------------------------------------------------- bad input
def bad(sw, **kw):
    args = dict(x=sw["x"], fs=FS, pulse_times=sw["pulses"], cycle_order=1)
    args.update(kw)
    return tsa.residual(**args)


def test_rejects_non_increasing_pulses(sw):
    p = sw["pulses"].copy()
    p[[10, 11]] = p[[11, 10]]
    with pytest.raises(PulseError, match=r"at sample 11: must be strictly increasing.*unique"):
        bad(sw, pulse_times=p)


def test_rejects_missing_pulse(sw):
    p = np.delete(sw["pulses"], 50)
    with pytest.raises(PulseError, match=r"at sample 49: has 1 missing pulse.*repair=True"):
        bad(sw, pulse_times=p)


def test_rejects_extra_pulse(sw):
    p = np.sort(np.append(sw["pulses"], 0.5 * (sw["pulses"][40] + sw["pulses"][41]) + 0.01))
    with pytest.raises(PulseError, match=r"extra pulse"):
        bad(sw, pulse_times=p)


def test_rejects_jittery_pulses(sw):
    p = sw["pulses"].copy()
    dt = np.diff(p).min()
    p[1:-1] += np.random.default_rng(0).normal(0, 0.2 * dt, p.size - 2)
    with pytest.raises(PulseError, match=r"pulse_times at sample \d+: jittery.*threshold"):
        bad(sw, pulse_times=np.sort(p))


def test_rejects_too_few_cycles(sw):
    with pytest.raises(ValueError, match=r"cycles of cycle_order.*n_cycles=10.*longer record"):
        bad(sw, cycle_order=0.01)


def test_rejects_nan_in_signal(sw):
    x = sw["x"].copy()
    x[1234] = np.nan
    with pytest.raises(DataError, match=r"x at sample 1234: contains 1 NaN/inf.*index 1234.*fill"):
        bad(sw, x=x)


@pytest.mark.parametrize("order", [0, -1.0, np.nan, Fraction(-1, 3)])
def test_rejects_non_positive_cycle_order(sw, order):
    with pytest.raises(ValueError, match=r"cycle_order must be > 0"):
        bad(sw, cycle_order=order)


def test_rejects_non_numeric_cycle_order(sw):
    with pytest.raises(TypeError, match=r"cycle_order must be a float or fractions.Fraction"):
        bad(sw, cycle_order="mesh2")


def test_rejects_pulses_beyond_record(sw):
    p = np.append(sw["pulses"], sw["t"][-1] + 0.05)
    with pytest.raises(PulseError, match=r"pulse_times at sample \d+: span .* record covers .* t0"):
        bad(sw, pulse_times=p)


def test_rejects_bad_counts_and_options(sw):
    with pytest.raises(ValueError, match=r"n_cycles must be an integer >= 2"):
        bad(sw, n_cycles=1)
    with pytest.raises(ValueError, match=r"fs must be a finite number > 0"):
        bad(sw, fs=0.0)
    with pytest.raises(ValueError, match=r"outside must be"):
        bad(sw, outside="drop")
    with pytest.raises(ValueError, match=r"band_limit must be in"):
        bad(sw, band_limit=1.5)
    with pytest.raises(ValueError, match=r"mode must be"):
        joint.residual_joint(sw["x"], FS, sw["pulses"], [1, MESH], mode="both")
    with pytest.raises(ValueError, match=r"cycle_orders\[1\] must be > 0"):
        joint.residual_joint(sw["x"], FS, sw["pulses"], [1, 0.0])
