"""gbpipe.model.chain: any torsional chain from its description.

A lab shaft line (motor – coupling hub – flywheel – gear pair – load motor) against a
hand-assembled reduced M, K and hand-computed damping; its loops against the batched
frequency-domain closing; a planetary stage on an elastic housing against the hand
model of tests/model/hand_models.py; each refusal naming its element.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scipy.linalg import eigh

from gbpipe import model
from gbpipe.config import merge, validate
from gbpipe.errors import ConfigError
from gbpipe.lti import frf
from gbpipe.model.chain import build_chain
from gbpipe.model.frf import Pairing, pairing_frf
from gbpipe.model.statespace import chain_plant, close_loops
from tests.model import hand_models

J = {"motor": 0.08, "hub": 0.01, "flywheel": 1.2, "wheel": 0.3, "pinion": 0.02, "load": 0.05}
K = [1.2e4, 8.0e3, 2.0e4, 3.0e3]
TEETH = (96, 29)


def _params(seed: int | None) -> tuple[dict, list, tuple]:
    """The nominal shaft line (seed None) or one drawn over decades of J, k and ratios."""
    if seed is None:
        return J, K, TEETH
    rng = np.random.default_rng(seed)
    j = {n: float(v) for n, v in zip(J, 10 ** rng.uniform(-3, 1, len(J)), strict=True)}
    k = [float(v) for v in 10 ** rng.uniform(2, 6, len(K))]
    return j, k, (int(rng.integers(20, 120)), int(rng.integers(12, 40)))


def shaft_line(seed: int | None = None) -> dict:
    """A lab shaft line: speed-controlled motor, flywheel, gear pair, torque-loop load."""
    J, K, TEETH = _params(seed)
    return {
        "name": "lab shaft line",
        "disks": {n: {"inertia": j} for n, j in J.items()},
        "shafts": [
            {"name": "s1", "between": ["motor", "hub"], "stiffness": K[0], "damping_ratio": 0.02},
            {"name": "s2", "between": ["hub", "flywheel"], "stiffness": K[1], "damping": 0.5},
            {"name": "s3", "between": ["flywheel", "wheel"], "stiffness": K[2],
             "damping_ratio": 0.03},
            {"name": "s4", "between": ["pinion", "load"], "stiffness": K[3],
             "damping_ratio": 0.02}],
        "gears": [{"name": "g1", "parent": "wheel", "child": "pinion", "teeth": list(TEETH)}],
        "motors": [
            {"name": "driver", "node": "motor", "sign": 1, "torque_limit": 50.0, "ripple": 1.0,
             "controller": {"type": "speed", "sensor": "speed_motor", "kp": 2.0, "ki": 20.0,
                            "setpoint_weight": 0.5}},
            {"name": "load", "node": "load", "sign": -1, "ripple": 1.0,
             "controller": {"type": "torque", "sensor": "torque_s4", "kp": 0.2, "ki": 5.0,
                            "feedforward": 1.0}}],
        "sensors": [{"name": "speed_motor", "speed": "motor"},
                    {"name": "speed_load", "speed": "load"},
                    {"name": "torque_s4", "torque": "s4", "sign": 1},
                    {"name": "angle_flywheel", "angle": "flywheel"}],
        "excitation": [{"name": "te_g1", "shaft": "s3"}],
    }


def _hand_mk(seed: int | None) -> tuple[np.ndarray, np.ndarray, float]:
    """Reduced M, K on q = [motor, hub, flywheel, wheel, load]; pinion = r·wheel."""
    J, K, TEETH = _params(seed)
    r = TEETH[0] / TEETH[1]
    M = np.diag([J["motor"], J["hub"], J["flywheel"], J["wheel"] + r ** 2 * J["pinion"],
                 J["load"]])
    Kq = np.zeros((5, 5))
    for k, g in zip(K, ([1, -1, 0, 0, 0], [0, 1, -1, 0, 0], [0, 0, 1, -1, 0],
                        [0, 0, 0, r, -1]), strict=True):
        Kq += k * np.outer(g, g)
    return M, Kq, r


@pytest.mark.parametrize("seed", [None, 1, 2, 3])
def test_shaft_line_matrices_modes_and_damping(seed):
    chain = build_chain(shaft_line(seed))
    mech = chain.mechanism
    J, K, _ = _params(seed)
    M, Kq, r = _hand_mk(seed)
    assert mech.coords == ["motor", "hub", "flywheel", "wheel", "load"]
    np.testing.assert_allclose(mech.mass_matrix, M, rtol=1e-12)
    np.testing.assert_allclose(mech.stiffness_matrix, Kq, rtol=1e-12)
    w2 = eigh(Kq, M, eigvals_only=True)
    np.testing.assert_allclose(mech.undamped_frequencies(),
                               np.sqrt(w2[1:]) / (2 * np.pi), rtol=1e-9)
    # c = 2ξ√(k J_eq), the groups referred to the spring's speed (the gear pair is one
    # group: J_wheel + r² J_pinion at the wheel, the same over r² at the pinion)
    jw = J["wheel"] + r ** 2 * J["pinion"]
    def c(k, ja, jb, xi):
        return 2 * xi * np.sqrt(k * ja * jb / (ja + jb))
    expected = {"s1": c(K[0], J["motor"], J["hub"], 0.02), "s2": 0.5,
                "s3": c(K[2], J["flywheel"], jw, 0.03),
                "s4": c(K[3], jw / r ** 2, J["load"], 0.02)}
    for s in mech.springs:
        assert s.damping == pytest.approx(expected[s.name], rel=1e-12)


def test_shaft_line_loops_and_names():
    chain = build_chain(shaft_line())
    plant = chain_plant(chain)
    assert plant.inputs == ["motor_torque_driver", "motor_torque_load", "te_g1"]
    assert plant.outputs == ["speed_motor", "speed_load", "torque_s4", "angle_flywheel"]
    closed = close_loops(plant, chain.motors)
    assert closed.inputs[:4] == ["speed_ref", "torque_ref", "disturbance_driver",
                                 "disturbance_load"]
    assert closed.states[-2:] == ["integral_speed_error", "integral_torque_error"]
    ev = np.linalg.eigvals(closed.A)
    assert ev.real.max() < 1e-9 * np.abs(ev).max()
    # integral action: speed follows its reference, the shaft torque its reference (the
    # load brakes with sign −1, so the meter reads +torque_ref in steady state)
    g0 = frf(closed.select(["speed_ref", "torque_ref"], ["speed_motor", "torque_s4"]),
             [1e-6])[0]
    np.testing.assert_allclose(np.diag(g0).real, [1.0, 1.0], rtol=1e-6)
    # batched frequency-domain closing equals the truth model's state space
    f = np.geomspace(0.5, 200.0, 30)
    desc_cfg = {"drivetrain": shaft_line()}
    pairings = [Pairing("a", ("motor_torque_driver",), ("speed_load", "torque_s4")),
                Pairing("b", ("motor_torque_load",), ("speed_motor",)),
                Pairing("c", ("motor_torque_load", "motor_torque_driver"), ("speed_load",))]
    for p, g in zip(pairings, pairing_frf(desc_cfg, pairings, f), strict=True):
        ref = frf(model.truth_model(desc_cfg, p.inputs, p.outputs), f)
        np.testing.assert_allclose(g, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())


def test_two_speed_motors_get_suffixed_references():
    desc = shaft_line()
    desc["motors"][1]["controller"] = {"type": "speed", "sensor": "speed_load", "kp": 0.1,
                                       "ki": 0.0}
    chain = build_chain(desc)
    closed = close_loops(chain_plant(chain), chain.motors)
    assert closed.inputs[:2] == ["speed_ref_driver", "speed_ref_load"]
    assert "integral_speed_error_load" in closed.states


def test_planetary_on_elastic_housing_equals_the_hand_gearbox(cfg_example):
    """One planetary stage (ring on the housing) + parallel stages on an elastic mount,
    written as a description by hand, against hand_models.gearbox_matrices."""
    gb = cfg_example["gearbox"]
    st = gb["stages"]
    disks = {"housing": {"inertia": gb["housing"]["inertia"]}}
    planetary, gears, shafts = [], [], []
    for i, s in enumerate(st, start=1):
        if s["type"] == "planetary":
            disks |= {f"c{i}": {"inertia": gb["inertia"][i - 1]}, f"p{i}": {"inertia": 0.0},
                      f"s{i}": {"inertia": 0.0}}
            planetary.append({"name": f"st{i}", "carrier": f"c{i}", "planet": f"p{i}",
                              "sun": f"s{i}", "ring": "housing", "planets": s["planets"],
                              "teeth": {k: s[k] for k in ("ring", "planet", "sun")}})
        else:
            disks |= {f"w{i}": {"inertia": gb["inertia"][i - 1]}, f"n{i}": {"inertia": 0.0}}
            gears.append({"name": f"g{i}", "parent": f"w{i}", "child": f"n{i}",
                          "teeth": [s["wheel"], s["pinion"]], "housing": "housing"})
    disks["flange"] = {"inertia": gb["inertia"][-1]}
    ins = [f"c{i}" if s["type"] == "planetary" else f"w{i}" for i, s in enumerate(st, 1)]
    outs = [f"s{i}" if s["type"] == "planetary" else f"n{i}" for i, s in enumerate(st, 1)]
    for i in range(len(st)):
        shafts.append({"name": f"k{i}", "between": [(ins[1:] + ["flange"])[i], outs[i]],
                       "stiffness": gb["stiffness"][i], "damping_ratio": 0.04})
    desc = {"disks": disks, "shafts": shafts, "planetary": planetary, "gears": gears,
            "mounts": [{"name": "arm", "node": "housing",
                        "stiffness": gb["housing"]["stiffness"], "damping_ratio": 0.04}]}
    mech = build_chain(desc).mechanism
    M, Kh = hand_models.gearbox_matrices(gb)
    np.testing.assert_allclose(mech.mass_matrix, M, rtol=1e-12)
    np.testing.assert_allclose(mech.stiffness_matrix, Kh, rtol=1e-12,
                               atol=1e-12 * np.abs(Kh).max())
    np.testing.assert_allclose(mech.undamped_frequencies(), hand_models.frequencies(M, Kh),
                               rtol=1e-9)


def _set(desc: dict, path: list, value) -> dict:
    out = copy.deepcopy(desc)
    node = out
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return out


BAD = [
    (["gears", 0, "parent"], "shaft", "drivetrain.gears[0].parent"),
    (["gears", 0, "child"], "wheel", "drivetrain.gears[0].child"),
    (["sensors", 2, "torque"], "s9", "drivetrain.sensors[2].torque"),
    (["sensors", 0, "speed"], "nowhere", "drivetrain.sensors[0].speed"),
    (["motors", 0, "node"], "rotor", "drivetrain.motors[0].node"),
    (["motors", 0, "controller", "sensor"], "torque_s4", "drivetrain.motors[0].controller.sensor"),
    (["shafts", 0, "stiffness"], 0.0, "drivetrain.shafts[0].stiffness"),
    (["shafts", 3, "stiffness"], -5.0, "drivetrain.shafts[3].stiffness"),
    (["shafts", 1, "name"], "s1", "drivetrain.shafts[1].name"),
    (["shafts", 0, "damping"], 1.0, "drivetrain.shafts[0].damping"),
    (["disks", "hub", "inertia"], 0.0, "drivetrain.disks.hub"),
    (["excitation", 0, "shaft"], "g1", "drivetrain.excitation[0].shaft"),
]


@pytest.mark.parametrize("path, value, field", BAD, ids=[b[2] for b in BAD])
def test_bad_element_is_named(path, value, field):
    with pytest.raises(ConfigError) as exc:
        build_chain(_set(shaft_line(), path, value))
    assert exc.value.field == field


def test_constrained_twice_disconnected_and_floating_parts_are_named():
    desc = shaft_line()
    twice = copy.deepcopy(desc)
    twice["gears"].append({"name": "g2", "parent": "flywheel", "child": "pinion",
                           "ratio": 2.0})
    with pytest.raises(ConfigError) as exc:
        build_chain(twice)
    assert exc.value.field == "drivetrain.gears[1].child" and "g1" not in exc.value.field
    lone = _set(desc, ["disks", "spare"], {"inertia": 1.0})
    with pytest.raises(ConfigError) as exc:
        build_chain(lone)
    assert exc.value.field == "drivetrain.disks.spare"
    # cut s3: {flywheel, hub, motor} is driven, {wheel, pinion, load} by the load motor;
    # drop the load motor too and that part floats
    cut = copy.deepcopy(desc)
    cut["shafts"] = [s for s in cut["shafts"] if s["name"] != "s3"]
    cut["excitation"] = []
    build_chain(cut)
    cut["motors"] = cut["motors"][:1]
    with pytest.raises(ConfigError) as exc:
        build_chain(cut)
    assert exc.value.field == "drivetrain.disks"
    assert all(n in str(exc.value) for n in ("wheel", "pinion", "load"))


def _campaign_keys() -> dict:
    """What a config with the shaft line needs beside it: the simulated campaign's keys on
    the chain's own motors and sensors (the paper's pairings, TSA versions and fit are
    refused on it, rightly; the motors carry their ripple)."""
    return {"fit": {"records": []},
            "identify": {"versions": ["clean", "raw"],
                         "pairings": [{"name": "Td_to_wm", "inputs": ["motor_torque_driver"],
                                       "outputs": ["speed_motor"]}],
                         "best": {"pairing": "Td_to_wm", "version": "raw"}}}


def test_config_drivetrain_section_drives_the_models(cfg):
    desc = shaft_line()
    custom = validate(merge(cfg, {"drivetrain": desc, **_campaign_keys()}))
    ss = model.bench_ss(custom, closed=False)
    assert ss.outputs == ["speed_motor", "speed_load", "torque_s4", "angle_flywheel"]
    model.check_stability(custom)
    bad = merge(cfg, {"drivetrain": _set(desc, ["motors", 1, "controller", "ki"], 5.0e3)})
    with pytest.raises(ConfigError) as exc:
        model.check_stability(bad)
    assert exc.value.field.startswith("drivetrain.motors[1].controller.k")
    with pytest.raises(ConfigError) as exc:
        validate(merge(cfg, {"drivetrain": _set(desc, ["gears", 0, "parent"], "x"),
                             **_campaign_keys()}))
    assert exc.value.field == "drivetrain.gears[0].parent"
    dotted = _set(desc, ["disks", "gb.spare"], {"inertia": 1.0})
    with pytest.raises(ConfigError) as exc:
        validate(merge(cfg, {"drivetrain": dotted, **_campaign_keys()}))
    assert exc.value.field == "drivetrain.disks.gb.spare"


def test_stability_accepts_bounded_modes_at_zero(cfg):
    """A mount turns the rigid angle into a static mode (the speed integrator against the
    mount: no speed, a held torque); a cut shaft leaves two rigid parts, each with its
    speed loop. Both are bounded eigenvalues at 0, not instability."""
    grounded = shaft_line()
    grounded["mounts"] = [{"name": "m", "node": "flywheel", "stiffness": 1.0e3}]
    cut = shaft_line()
    cut["shafts"] = [s for s in cut["shafts"] if s["name"] != "s3"]
    cut["excitation"] = []
    cut["motors"][1] |= {"sign": 1, "controller": {"type": "speed", "sensor": "speed_load",
                                                   "kp": 0.1, "ki": 0.5}}
    for desc, zeros in ((grounded, 1), (cut, 2)):
        chain = build_chain(desc)
        closed = close_loops(chain_plant(chain), chain.motors)
        ev, vec = np.linalg.eig(closed.A)
        scale = np.abs(ev).max()
        at_zero = np.abs(ev) < 1e-9 * scale
        assert at_zero.sum() == zeros
        assert np.all(ev[~at_zero].real < 0)
        n = len(chain.mechanism.coords)
        if desc is grounded:      # the static mode: every speed zero, the integrator not
            v = vec[:, np.argmax(at_zero)]
            assert np.abs(v[n:2 * n]).max() < 1e-9 * np.abs(v).max()
            assert abs(v[closed.states.index("integral_speed_error")]) > 0.1 * np.abs(v).max()
        model.check_stability(merge(cfg, {"drivetrain": desc}))


def test_a_part_whose_speed_nothing_holds_is_refused(cfg):
    """Cut the line and leave the load part to its torque loop: its speed drifts."""
    cut = shaft_line()
    cut["shafts"] = [s for s in cut["shafts"] if s["name"] != "s3"]
    cut["excitation"] = []
    with pytest.raises(ConfigError) as exc:
        model.check_stability(merge(cfg, {"drivetrain": cut}))
    assert exc.value.field == "drivetrain.motors" and "speed" in exc.value.problem


def test_three_motors_batched_closing_equals_truth():
    """Two loops to close around a one-input pairing: the matrix form of the closing."""
    desc = shaft_line()
    desc["sensors"].append({"name": "speed_flywheel", "speed": "flywheel"})
    desc["motors"].append({"name": "aux", "node": "flywheel", "sign": 1,
                           "controller": {"type": "speed", "sensor": "speed_flywheel",
                                          "kp": 1.0, "ki": 3.0}})
    cfg_desc = {"drivetrain": desc}
    f = np.geomspace(0.5, 200.0, 25)
    pairings = [Pairing("a", ("motor_torque_load",), ("speed_motor", "torque_s4")),
                Pairing("b", ("motor_torque_aux", "motor_torque_driver"), ("speed_load",))]
    for p, g in zip(pairings, pairing_frf(cfg_desc, pairings, f), strict=True):
        ref = frf(model.truth_model(cfg_desc, p.inputs, p.outputs), f)
        np.testing.assert_allclose(g, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
    closed = model.bench_ss(cfg_desc)
    assert closed.inputs[:3] == ["speed_ref_driver", "torque_ref", "speed_ref_aux"]
