"""The paper's bench through the drivetrain builder equals its former construction.

The reference is :mod:`frozen_bench` (tests/model/frozen_bench.py): the construction of
``gearbox:`` + ``bench:`` into mechanisms and the two hand-closed PI loops as they were
before the builder, kept only in the tests. State spaces (names, order, A, B, C, D),
truth models and the batched pairing FRFs must agree to 1e-9 relative, for the paper's
gearbox, the example gearbox (1 planetary + 2 parallel stages), a fixed housing, and
member-wise stage inertias.
"""

from __future__ import annotations

import numpy as np
import pytest

from gbpipe import model
from gbpipe.config import merge
from gbpipe.lti import NamedSS, frf
from gbpipe.model.frf import Pairing, pairing_frf
from tests.model.frozen_bench import bench_ss as frozen_bench_ss
from tests.model.frozen_bench import gearbox_ss as frozen_gearbox_ss

FIXED = {"gearbox": {"housing": {"mount": "fixed"}}}
MEMBERWISE = {"gearbox": {"inertia": [{"carrier": 6000.0, "planet": 90.0, "sun": 12.0},
                                      {"carrier": 500.0, "planet": 20.0, "sun": 4.0},
                                      {"wheel": 170.0, "pinion": 3.0}, 5.0]}}


def _same(a: NamedSS, b: NamedSS) -> None:
    assert (a.states, a.inputs, a.outputs) == (b.states, b.inputs, b.outputs)
    assert a.units == b.units
    for x, y in zip((a.A, a.B, a.C, a.D), (b.A, b.B, b.C, b.D), strict=True):
        np.testing.assert_allclose(x, y, rtol=1e-9, atol=1e-9 * max(np.abs(y).max(), 1e-300))


@pytest.fixture(params=["cfg", "cfg_example", "fixed", "memberwise"])
def variant(request):
    if request.param in ("cfg", "cfg_example"):
        return request.getfixturevalue(request.param)
    base = request.getfixturevalue("cfg")
    return merge(base, FIXED if request.param == "fixed" else MEMBERWISE)


def _frozen_truth(cfg, inputs, outputs) -> NamedSS:
    """The former truth model: the other loop closed, the pairing's loop at zero gains."""
    if len(inputs) == 2:
        return frozen_bench_ss(cfg, closed=False).select(inputs, outputs)
    if inputs[0] == "motor_torque_driver":
        ss = frozen_bench_ss(cfg, speed_gains=(0.0, 0.0)).select(["disturbance_driver"],
                                                                  outputs)
    else:
        ss = frozen_bench_ss(cfg, torque_gains=(0.0, 0.0)).select(["disturbance_driven"],
                                                                   outputs)
    ss.inputs = list(inputs)
    return ss


def test_state_spaces_equal_the_former_construction(variant):
    _same(model.gearbox_ss(variant), frozen_gearbox_ss(variant))
    _same(model.bench_ss(variant, closed=False), frozen_bench_ss(variant, closed=False))
    _same(model.bench_ss(variant), frozen_bench_ss(variant))


def test_truth_and_batched_frfs_equal_the_former_truth(cfg):
    f = np.geomspace(1.0, 400.0, 40)
    pairings = [Pairing.from_config(p) for p in cfg["identify"]["pairings"]]
    pairings.append(Pairing("both", ("motor_torque_driver", "motor_torque_driven"),
                            ("speed_gb1_hss", "torque_meter_driving")))
    got = pairing_frf(cfg, pairings, f)
    for p, g in zip(pairings, got, strict=True):
        ref_ss = _frozen_truth(cfg, p.inputs, p.outputs)
        new_ss = model.truth_model(cfg, p.inputs, p.outputs)
        np.testing.assert_array_equal(new_ss.A, ref_ss.A)
        np.testing.assert_array_equal(new_ss.B, ref_ss.B)
        ref = frf(ref_ss, f)
        np.testing.assert_allclose(g, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())


def test_paper_description_follows_the_config(cfg):
    desc = model.paper_drivetrain(cfg)
    assert [m["name"] for m in desc["motors"]] == ["driver", "driven"]
    assert desc["motors"][1]["sign"] == -1
    assert desc["motors"][0]["controller"]["kp"] == cfg["bench"]["speed_controller"]["kp"]
    # a stage inertia given as one number sits on the stage's input member
    assert desc["disks"]["gb1.carrier1"]["inertia"] == cfg["gearbox"]["inertia"][0]
    assert desc["disks"]["gb1.sun1"]["inertia"] == 0.0
