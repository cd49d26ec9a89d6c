"""The batched pairing FRF (gbpipe.model.frf) against the truth models' state-space FRF."""

from __future__ import annotations

import numpy as np
import pytest

from gbpipe.errors import ConfigError
from gbpipe.fit.keypath import get_value, overlay, with_values
from gbpipe.lti import frf
from gbpipe.model import gearbox_ss, truth_model
from gbpipe.model.frf import Pairing, mechanical_frf, pairing_frf

F = np.geomspace(5.0, 350.0, 240)


def _refined_frf(ss, f_hz: np.ndarray, iterations: int = 3) -> np.ndarray:
    """``C (sI − A)⁻¹ B + D`` with the residual of each solve in extended precision.

    Mixed-precision iterative refinement: independent of both the batched path and the
    plain double solve of gbpipe.lti.frf, whose round-off reaches 1e-6 on the bench's weak
    cross paths (45 dB below the direct ones).
    """
    a, b, c = (np.asarray(m, dtype=np.longdouble) for m in (ss.A, ss.B, ss.C))
    s = (2j * np.pi * f_hz).astype(np.clongdouble)
    z = s[:, None, None] * np.eye(a.shape[0], dtype=np.longdouble) - a
    z64 = z.astype(complex)
    x = np.linalg.solve(z64, np.broadcast_to(ss.B, (f_hz.size, *ss.B.shape))).astype(
        np.clongdouble)
    for _ in range(iterations):
        x = x + np.linalg.solve(z64, (b - z @ x).astype(complex)).astype(np.clongdouble)
    return (c @ x).astype(complex) + ss.D


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b) / np.abs(b)))


def test_pairings_equal_truth_models(cfg):
    pairings = [Pairing.from_config(p) for p in cfg["identify"]["pairings"]]
    batched = pairing_frf(cfg, pairings, F)
    for p, g in zip(pairings, batched, strict=True):
        model = truth_model(cfg, p.inputs, p.outputs)
        # the accurate reference of the same 26-state closed loop
        assert _rel(g, _refined_frf(model, F)) < 1e-9, p.name
        # gbpipe's own FRF: equal to 1e-9 except where its round-off is larger (cross
        # paths of the driven-motor input, checked against the refined one above)
        plain = frf(model, F)
        tol = 1e-9 if "motor_torque_driven" not in p.inputs else 1e-5
        assert _rel(g, plain) < tol, p.name


def test_gearbox_second_order_path_equals_state_space_path(cfg):
    gb = gearbox_ss(cfg)
    assert _rel(mechanical_frf(gb, F), frf(gb, F)) < 1e-9


def test_closed_loop_state_space_is_refused(cfg):
    with pytest.raises(ValueError, match="mechanism state space"):
        mechanical_frf(truth_model(cfg, ["motor_torque_driver"], ["speed_gb2_hss"]), F)


def test_parameter_change_moves_the_resonance_as_sqrt_k(cfg):
    """Coupling stiffness ×1.21 moves the 62 Hz coupling mode by ≈ ×1.1 (it dominates)."""
    p = Pairing("p", ("motor_torque_driver",), ("speed_gb2_hss",))
    f = np.linspace(40.0, 90.0, 5001)
    k = get_value(cfg, "bench.coupling.stiffness")
    stiff = with_values(cfg, {"bench.coupling.stiffness": 1.21 * k})
    peak = [f[np.argmax(np.abs(pairing_frf(c, [p], f)[0][:, 0, 0]))] for c in (cfg, stiff)]
    assert 1.05 < peak[1] / peak[0] < 1.11
    assert get_value(cfg, "bench.coupling.stiffness") == k    # caller's config untouched


def test_key_paths(cfg):
    assert get_value(cfg, "gearbox.stiffness[1]") == cfg["gearbox"]["stiffness"][1]
    new = with_values(cfg, {"gearbox.stiffness[1]": 2.0e7})
    assert new["gearbox"]["stiffness"] == [cfg["gearbox"]["stiffness"][0], 2.0e7,
                                           cfg["gearbox"]["stiffness"][2]]
    assert cfg["gearbox"]["stiffness"][1] != 2.0e7
    assert overlay(new, ["gearbox.stiffness[1]", "bench.coupling.stiffness"]) == {
        "gearbox": {"stiffness": new["gearbox"]["stiffness"]},
        "bench": {"coupling": {"stiffness": cfg["bench"]["coupling"]["stiffness"]}}}
    for bad in ("gearbox.stiffness[7]", "gearbox..inertia", "gearbox.housing", "nope"):
        with pytest.raises(ConfigError):
            get_value(cfg, bad)
    with pytest.raises(ConfigError, match="motor torques"):
        Pairing("x", ("speed_ref",), ("speed_gb2_hss",))
