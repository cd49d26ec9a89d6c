"""The chi-square goodness-of-fit test (gbpipe.fit.goodness) against its closed form,
and a fit with a wrong stiffness that must say it is poor."""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter
from scipy.stats import binom

from gbpipe.fit.estimate import fit_parameters
from gbpipe.fit.frf_data import FrfData
from gbpipe.fit.goodness import chi_square_test
from gbpipe.fit.keypath import get_value, with_values
from gbpipe.fit.residuals import correlation_factor
from gbpipe.model.frf import Pairing, pairing_frf

ALPHA = 0.01


def _pass_rate(draw, n_seeds: int, n_unknowns: int = 0) -> int:
    passed = 0
    for seed in range(n_seeds):
        r = draw(np.random.default_rng(seed))
        labels = np.repeat(np.arange(4), r.size // 4)
        f = np.tile(np.geomspace(1.0, 100.0, r.size // 4), 4)
        g = chi_square_test(r, n_unknowns, correlation_factor(r, labels),
                            np.repeat(["a", "b"], r.size // 2), f, alpha=ALPHA)
        passed += g.status == "passed"
    return passed


def test_honest_residuals_pass_at_the_stated_level():
    """White unit-variance residuals pass in about 1 - alpha of the seeds: the count lies
    inside the binomial 99.9 % range of n(1 - alpha); correlated AR(1) residuals of unit
    variance too (the correlation factor is what keeps them from failing)."""
    n = 300
    lo, hi = binom.ppf([0.0005, 0.9995], n, 1 - ALPHA)
    white = _pass_rate(lambda rng: rng.standard_normal(800), n)
    assert lo <= white <= hi
    a = 0.6         # AR(1) with unit variance: innovations scaled by sqrt(1 - a²)
    ar = _pass_rate(lambda rng: np.concatenate(
        [lfilter([np.sqrt(1 - a * a)], [1.0, -a], rng.standard_normal(400))[100:]
         for _ in range(4)]), n)
    assert ar >= lo
    # residuals twice the stated sigma fail every time
    assert _pass_rate(lambda rng: 2.0 * rng.standard_normal(800), 50) == 0


def test_a_wrong_stiffness_makes_the_fit_poor_and_names_the_misfit(cfg):
    """The LSS shaft of the data is 40 % stiffer than the model's and is not freed: the
    fit of two other stiffnesses to the driven-side FRF with its sigma cannot reach the
    data's bounds: status poor, no parameter identified, the reason names the pairing;
    the same fit with the right LSS stiffness passes and identifies."""
    pairing = Pairing("Tdrn_to_wdrn", ("motor_torque_driven",), ("speed_gb1_hss",))
    f = np.geomspace(5.0, 350.0, 80)
    free = ["gearbox.housing.stiffness", "bench.coupling.stiffness"]
    sigma = 0.02
    rng = np.random.default_rng(7)
    results = []
    for lss in (1.4, 1.0):
        truth = with_values(cfg, {"bench.lss_shaft.stiffness":
                                  get_value(cfg, "bench.lss_shaft.stiffness") * lss,
                                  free[0]: get_value(cfg, free[0]) * 0.8})
        (g,) = pairing_frf(truth, [pairing], f)
        noisy = g * np.exp(sigma * (rng.standard_normal(g.shape)
                                    + 1j * rng.standard_normal(g.shape)))
        results.append(fit_parameters(cfg, [FrfData(pairing, f, noisy, sigma)], free,
                                      n_starts=2, n_global=4, search="starts"))
    wrong, right = results
    assert wrong.goodness.status == "poor" and wrong.goodness.p_value < ALPHA
    assert not wrong.identified.any() and set(wrong.status) <= {"poor", "conditional",
                                                                 "unidentifiable"}
    assert "Tdrn_to_wdrn" in wrong.goodness.reason and "Hz" in wrong.goodness.reason
    # passed: no parameter is poor (one known worse than fit.accuracy is held instead)
    assert right.goodness.status == "passed" and "poor" not in right.status
    assert right.identified.any()
