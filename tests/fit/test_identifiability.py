"""Identifiability: SVD of the Jacobian, honest flags, design help (gbpipe.model)."""

from __future__ import annotations

import numpy as np
import pytest

from gbpipe.fit.estimate import fit_parameters
from gbpipe.fit.frf_data import FrfData, sigma_from_bounds, sigma_from_coherence
from gbpipe.fit.identifiability import analyse, describe_direction, design_outputs
from gbpipe.fit.keypath import get_value, with_values
from gbpipe.model.frf import Pairing, pairing_frf

# one output, 5–50 Hz: the housing-mount mode (27.8 Hz) shows its frequency, not the
# housing inertia and mount stiffness apart; the coupling shapes the whole band
PAIRING = Pairing("Tdrv_to_wdrv", ("motor_torque_driver",), ("speed_gb2_hss",))
F_LOW = np.geomspace(5.0, 50.0, 120)
HOUSING = ["gearbox.housing.stiffness", "gearbox.housing.inertia", "bench.coupling.stiffness"]
SIGMA = 0.05


def test_hand_built_jacobian():
    """J over (ln J, ln k, ln c) that sees only k/J and c: ratio named, c determined."""
    rng = np.random.default_rng(3)
    d1, d2 = rng.standard_normal((50, 1)), rng.standard_normal((50, 1))
    d2 -= d1 * (d1.T @ d2) / (d1.T @ d1)     # c's effect orthogonal to the ratio's
    jac = np.hstack([-d1, d1, d2]) * 10.0
    res = analyse(jac, ["inertia[1]", "stiffness[1]", "damping"])
    assert res.rank == 2
    assert list(res.flagged) == [True, True, False]
    assert res.combinations == ["`inertia[1]` and `stiffness[1]` only as their ratio "
                                "(`inertia[1]`/`stiffness[1]`)"]
    # the determined parameter's variance is the least-squares one: 1 / Σ (10·d2)²
    assert res.sd[2] == pytest.approx(1.0 / np.linalg.norm(jac[:, 2]), rel=1e-12)
    assert np.isinf(res.sd[:2]).all()
    assert "product" in describe_direction(np.array([0.7, -0.7]), ["a", "b"])
    assert "no visible effect" in describe_direction(np.array([0.0, 1.0]), ["a", "b"])


def test_single_output_cannot_separate_housing_pair(cfg):
    truth = with_values(cfg, {p: get_value(cfg, p) * k
                              for p, k in zip(HOUSING, (1.2, 1.2, 0.9), strict=True)})
    (g,) = pairing_frf(truth, [PAIRING], F_LOW)
    rng = np.random.default_rng(1)
    noisy = g * (1 + SIGMA * (rng.standard_normal(g.shape) + 1j * rng.standard_normal(g.shape)))
    res = fit_parameters(cfg, [FrfData(PAIRING, F_LOW, noisy, SIGMA)], HOUSING, n_starts=2)
    st = dict(zip(HOUSING, res.status, strict=True))
    assert st["bench.coupling.stiffness"] == "identified"
    assert {st[HOUSING[0]], st[HOUSING[1]]} == {"unidentifiable", "conditional"}
    fixed = HOUSING.index(next(p for p in HOUSING[:2] if st[p] == "unidentifiable"))
    assert res.value[fixed] == res.prior[fixed]                  # keeps its prior exactly
    assert np.isnan(res.interval[:2]).all()                      # never a confident number
    # the one structural combination (a weakly determined one may follow it)
    (ratio,) = res.identifiability.combinations
    assert res.combinations[0] == ratio
    assert "`gearbox.housing.inertia`" in ratio and "`gearbox.housing.stiffness`" in ratio
    assert "ratio" in ratio
    k_true = get_value(truth, "bench.coupling.stiffness")
    lo, hi = res.interval[2]
    assert lo <= k_true <= hi and abs(res.value[2] / k_true - 1) < 0.05


def test_design_names_outputs_that_separate_the_pair(cfg):
    candidates = [Pairing("Tdrv_to_Tmount2", ("motor_torque_driver",), ("torque_mount_gb2",)),
                  Pairing("Tdrv_to_wdrv_again", ("motor_torque_driver",), ("speed_gb2_hss",))]
    rows = design_outputs(cfg, HOUSING, [PAIRING], candidates, F_LOW, sigma=SIGMA)
    assert [r["added"] for r in rows] == [None, "Tdrv_to_Tmount2", "Tdrv_to_wdrv_again"]
    assert rows[0]["rank"] == 2 and rows[0]["identifiable"] == ["bench.coupling.stiffness"]
    # the mount torque sees the housing motion itself: every parameter identifiable
    assert rows[1]["rank"] == 3 and rows[1]["combinations"] == []
    # the same sensor again halves the variance only: still not a factor 1.5 apart
    assert rows[2]["rank"] == 2


def test_sigma_helpers():
    # Bendat & Piersol: γ² = 0.5, 50 averages -> ε = 1/√100 = 0.1
    assert sigma_from_coherence(0.5, 50) == pytest.approx(0.1)
    # a 95 % band of ×/÷ e^(1.96·0.1) gives σ = 0.1 Np
    assert sigma_from_bounds(np.exp(-1.959964 * 0.1), np.exp(1.959964 * 0.1)) == (
        pytest.approx(0.1, rel=1e-6))
