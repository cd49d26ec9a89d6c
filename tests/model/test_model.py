"""Torsional model against independent calculations."""

from __future__ import annotations

import control
import numpy as np
import pytest
from scipy.linalg import eigh
from scipy.signal import find_peaks

from gbpipe import kinematics, model
from gbpipe.config import merge, validate
from gbpipe.lti import frf, modes
from gbpipe.model.control_models import bench
from tests.model import hand_models

FIXED = {"gearbox": {"housing": {"mount": "fixed"}}}


def _reflected_chain(gb: dict) -> np.ndarray:
    """Undamped frequencies [Hz] of the gear chain reflected to the HSS, built by hand.

    Body i (stage group i, then the flange) has inertia J_i·o_i², shaft i stiffness k_i·s_i²,
    with o_i the HSS order of body i's speed and s_i that of shaft i's speed.
    """
    stages = gb["stages"]
    n = len(stages)
    shaft_order = [float(kinematics.order_of(stages, name))
                   for name in kinematics.shaft_names(n)]          # lss … hss
    J = np.array([gb["inertia"][i] * shaft_order[i] ** 2 for i in range(n)]
                 + [gb["inertia"][n]])
    k = np.array([gb["stiffness"][i] * shaft_order[i + 1] ** 2 for i in range(n)])
    K = np.zeros((n + 1, n + 1))
    for i, ki in enumerate(k):
        K[i:i + 2, i:i + 2] += ki * np.array([[1, -1], [-1, 1]])
    w2 = eigh(K, np.diag(J), eigvals_only=True)
    return np.sqrt(w2[w2 > 1e-6 * w2.max()]) / (2 * np.pi)


@pytest.mark.parametrize("which", ["cfg", "cfg_example"])
def test_fixed_housing_equals_reflected_chain(which, request):
    cfg = validate(merge(request.getfixturevalue(which), FIXED))
    mech, _ = model.gearbox_mechanism(cfg)
    np.testing.assert_allclose(mech.undamped_frequencies(), _reflected_chain(cfg["gearbox"]),
                               rtol=1e-6)


def test_default_gearbox_modes_match_design(cfg):
    mech, _ = model.gearbox_mechanism(validate(merge(cfg, FIXED)))
    # docs/architecture.md, "Physics": single-gearbox modes near 103, 194 and 315 Hz
    np.testing.assert_allclose(mech.undamped_frequencies(), [103, 194, 315], rtol=0.01)


@pytest.mark.parametrize("which", ["cfg", "cfg_example"])
@pytest.mark.parametrize("mount", ["fixed", "elastic"])
def test_static_torque_scales_with_ratio(which, mount, request):
    """Balanced static load: HSS torque T, LSS torque T·ratio; shaft k carries T/o_k."""
    cfg = validate(merge(request.getfixturevalue(which),
                         {"gearbox": {"housing": {"mount": mount}}}))
    ss = model.gearbox_ss(cfg)
    stages = cfg["gearbox"]["stages"]
    ratio = float(kinematics.total_ratio(stages))
    n = len(ss.states) // 2
    T = 1000.0
    # statics: A x + B u = 0 restricted to angles; K q = f has the rigid-body null space,
    # and f is orthogonal to it because the load is balanced through the gears.
    mech, ports = model.gearbox_mechanism(cfg)
    f = T * mech.torque_input(ports["hss"]) - T * ratio * mech.torque_input(ports["lss"])
    q = np.linalg.lstsq(mech.stiffness_matrix, f, rcond=None)[0]
    x = np.concatenate([q, np.zeros(n)])
    y = ss.C @ x
    orders = [float(kinematics.order_of(stages, s))
              for s in kinematics.shaft_names(len(stages))[1:]]
    for i, o in enumerate(orders, start=1):
        shaft_torque = y[ss.index("output", f"torque_shaft{i}")]
        assert abs(shaft_torque) == pytest.approx(T / o, rel=1e-9)
    if mount == "elastic":
        # the housing reacts the difference of LSS and HSS torques
        mount_torque = y[ss.index("output", "torque_mount")]
        assert abs(mount_torque) == pytest.approx(T * (ratio - 1), rel=1e-9)


@pytest.mark.parametrize("which", ["cfg", "cfg_example"])
def test_gearbox_frf_has_one_resonance_per_stage(which, request):
    cfg = validate(merge(request.getfixturevalue(which), FIXED))
    ss = model.gearbox_ss(cfg).select(["torque_hss"], ["speed_lss"])
    f = np.geomspace(5, 2000, 20000)
    # accelerance (jω·G): the rigid-body 1/ω slope becomes flat and cannot hide a peak
    mag = np.abs(2j * np.pi * f * frf(ss, f)[:, 0, 0])
    peaks, _ = find_peaks(20 * np.log10(mag), prominence=3)
    assert len(peaks) == len(cfg["gearbox"]["stages"])
    mech, _ = model.gearbox_mechanism(cfg)
    np.testing.assert_allclose(f[peaks], mech.undamped_frequencies(), rtol=0.02)


def test_bench_has_mode_near_62_hz(cfg):
    fn, zeta = modes(model.bench_ss(cfg).A)
    assert np.any((fn > 58) & (fn < 66))
    assert np.all(zeta > 0)


def test_frf_matches_python_control(cfg):
    ss = model.bench_ss(cfg)
    sys = bench(cfg)
    f = np.array([0.5, 5.0, 61.9, 200.0])
    resp = control.frequency_response(sys, 2 * np.pi * f)
    np.testing.assert_allclose(frf(ss, f), np.moveaxis(resp.complex, -1, 0), rtol=1e-7,
                               atol=1e-12 * np.abs(resp.complex).max())


def test_named_io_and_closed_loop_steady_state(cfg):
    """Closed loop at DC: speed follows its reference, the torque meter the torque reference,
    the LSS shaft carries the torque times the ratio."""
    ss = model.bench_ss(cfg)
    sys = bench(cfg)
    assert sys.input_labels[:2] == ["speed_ref", "torque_ref"]
    assert "speed_gb1_hss" in sys.output_labels
    G = frf(ss, np.array([1e-6]))[0]
    ratio = float(kinematics.total_ratio(cfg["gearbox"]["stages"]))
    iw, it = ss.index("input", "speed_ref"), ss.index("input", "torque_ref")

    def gain(out, inp):
        return G[ss.index("output", out), inp].real

    for out in ("speed_gb1_hss", "speed_gb2_hss", "speed_driver_motor"):
        assert gain(out, iw) == pytest.approx(1.0, abs=1e-6)
    assert gain("speed_lss", iw) == pytest.approx(1 / ratio, rel=1e-6)
    assert gain("torque_meter_driven", it) == pytest.approx(1.0, abs=1e-6)
    assert gain("torque_meter_driving", it) == pytest.approx(1.0, abs=1e-6)
    assert gain("torque_lss_shaft", it) == pytest.approx(ratio, rel=1e-6)


def _housing_on_mounts(gb: dict) -> np.ndarray:
    """Undamped frequencies [Hz] of one gearbox on its mounts, assembled by hand."""
    return hand_models.frequencies(*hand_models.gearbox_matrices(gb))


def test_bench_modes_equal_the_hand_assembled_bench(cfg):
    mech, _ = model.bench_mechanism(cfg)
    np.testing.assert_allclose(mech.undamped_frequencies(),
                               hand_models.frequencies(*hand_models.bench_matrices(cfg)),
                               rtol=1e-6)


def test_elastic_mount_adds_the_housing_mode_of_the_readme(cfg):
    gb = cfg["gearbox"]
    assert gb["housing"]["mount"] == "elastic" and all(
        isinstance(j, float) for j in gb["inertia"])   # lumped inertias: the hand model's
    by_hand = _housing_on_mounts(gb)
    elastic, _ = model.gearbox_mechanism(cfg)
    fixed, _ = model.gearbox_mechanism(validate(merge(cfg, FIXED)))
    np.testing.assert_allclose(elastic.undamped_frequencies(), by_hand, rtol=1e-6)
    assert by_hand.size == fixed.undamped_frequencies().size + 1
    # README / docs/architecture.md, "Physics": a housing mode at 27.8 Hz, the first
    # stage mode moved from 103.5 to 124.9 Hz
    assert by_hand[0] == pytest.approx(27.8, abs=0.05)
    assert by_hand[1] == pytest.approx(124.9, abs=0.05)
    # the housing mode is the mount's: a 4x stiffer mount doubles it nearly (the gear
    # chain adds its own flexibility in series, so a little less than double)
    stiff = _housing_on_mounts({**gb, "housing": {**gb["housing"],
                                                  "stiffness": 4 * gb["housing"]["stiffness"]}})
    assert 1.5 * by_hand[0] < stiff[0] < 2.0 * by_hand[0]


@pytest.mark.parametrize("which", ["cfg", "cfg_example"])
def test_one_pass_spring_terms_equal_per_spring_ones(which, request):
    # the fit's assembly takes every spring's twist, K, C and error input in one pass; each
    # must be the same numbers as the per-spring definitions
    mech, _ = model.bench_mechanism(request.getfixturevalue(which))
    twist = mech.twist_maps()
    K, C = mech.spring_matrices(twist)
    k_sum, c_sum = np.zeros_like(K), np.zeros_like(C)
    for s in mech.springs:
        h = mech.twist_map(s)
        assert np.array_equal(twist[s.name], h)
        k_sum += s.stiffness * np.outer(h, h)
        c_sum += s.damping * np.outer(h, h)
    assert np.array_equal(K, k_sum) and np.array_equal(C, c_sum)
    names = [s.name for s in mech.springs]
    for name, e in zip(names, mech.angle_error_inputs(names, twist), strict=True):
        assert np.array_equal(e, -mech.spring(name).stiffness * twist[name])
