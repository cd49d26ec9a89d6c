"""Physical-parameter fit (gbpipe.fit.estimate) on FRFs simulated from a perturbed bench."""

from __future__ import annotations

import numpy as np
import pytest

from gbpipe.errors import ConfigError, DataError
from gbpipe.fit import jackknife_intervals
from gbpipe.fit.estimate import fit_parameters
from gbpipe.fit.frf_data import FrfData
from gbpipe.fit.keypath import get_value, parse_path, with_values
from gbpipe.model.frf import Pairing, pairing_frf

# the six: stiffness of stages 2 and 3, inertia of stage 1, housing mount
# stiffness, coupling stiffness, gear damping (unused by the rigid-gear model)
FREE = ["gearbox.stiffness[1]", "gearbox.stiffness[2]", "gearbox.inertia[0]",
        "gearbox.housing.stiffness", "bench.coupling.stiffness", "gearbox.damping_ratio.gear"]
FACTORS = [1.3, 0.7, 1.3, 0.7, 1.3, 1.3]


def _grid(cfg) -> np.ndarray:
    fr = cfg["identify"]["frf"]
    return np.geomspace(fr["f_min"], fr["f_max"], fr["points"])


def _truth(cfg):
    return with_values(cfg, {p: get_value(cfg, p) * k for p, k in zip(FREE, FACTORS,
                                                                        strict=True)})


def _pairings(cfg) -> list[Pairing]:
    return [Pairing.from_config(p) for p in cfg["identify"]["pairings"]]


def test_recovery_on_clean_frfs(cfg):
    truth, f, pairings = _truth(cfg), _grid(cfg), _pairings(cfg)
    data = [FrfData(p, f, g) for p, g in zip(pairings, pairing_frf(truth, pairings, f),
                                             strict=True)]
    res = fit_parameters(cfg, data, FREE)
    true = np.array([get_value(truth, p) for p in FREE])
    # no sigma (clean data): the five are determined, but nothing tested the residuals
    # against the data's errors, so none is called identified
    ident = res.determined
    assert list(res.status) == ["untested"] * 5 + ["unidentifiable"]
    assert res.goodness.status == "untested" and not res.identified.any()
    assert np.all(np.abs(res.value[ident] / true[ident] - 1) < 0.02)
    # gear damping has no relative coordinate to act on: flagged and kept at its prior
    assert res.status[5] == "unidentifiable" and res.value[5] == res.prior[5]
    assert "gearbox.damping_ratio.gear" in res.combinations[0]
    assert res.cost < 1e-12 * res.cost_prior
    # the overlay holds the fitted values at the same key paths
    ov = res.overlay()
    for i, p in enumerate(FREE):
        node = ov
        for key in parse_path(p):
            node = node[key]
        assert node == pytest.approx(res.value[i], rel=1e-12)


def test_noisy_intervals_cover_truth(cfg):
    """20 seeds, 10 % complex noise, known sigma, 60 frequencies (benchmarks/fit.py: the
    full 240-point grid and four starts)."""
    truth, pairings = _truth(cfg), _pairings(cfg)
    f = np.geomspace(5.0, 350.0, 60)
    clean = pairing_frf(truth, pairings, f)
    true = np.array([get_value(truth, p) for p in FREE[:5]])
    sigma, covered, worst, residuals = 0.1, [], 0.0, []
    for seed in range(20):
        rng = np.random.default_rng(seed)
        data = [FrfData(p, f, g * (1 + sigma * (rng.standard_normal(g.shape)
                                                + 1j * rng.standard_normal(g.shape))), sigma)
                for p, g in zip(pairings, clean, strict=True)]
        # the intervals are under test, not the global search (tests/fit/test_global.py):
        # the starts alone, as the 20 seeds would otherwise cost a differential evolution each
        res = fit_parameters(cfg, data, FREE[:5], n_starts=2, n_global=8, seed=seed,
                             search="starts")
        assert all(s == "identified" for s in res.status)
        worst = max(worst, float(np.max(np.abs(res.value / true - 1))))
        covered += list((res.interval[:, 0] <= true) & (true <= res.interval[:, 1]))
        residuals.append(res.residual)
    assert worst < 0.10
    # with the data's own sigma the weighted residuals have unit variance (19 200 of them)
    assert np.std(np.concatenate(residuals)) == pytest.approx(1.0, abs=0.02)
    assert np.mean(covered) >= 0.9     # 100 intervals


def test_bad_inputs_are_named(cfg):
    f = _grid(cfg)
    p = _pairings(cfg)[0]
    (g,) = pairing_frf(cfg, [p], f)
    with pytest.raises(ConfigError, match="gearbox.stiffness"):
        fit_parameters(cfg, [FrfData(p, f, g)], ["gearbox.stiffness"])
    with pytest.raises(ConfigError, match="bench.coupling.stiffness"):
        fit_parameters(cfg, [FrfData(p, f, g)], ["bench.coupling.stiffness"],
                       bounds={"bench.coupling.stiffness": (1.0, 2.0)})
    with pytest.raises(DataError, match="shape"):
        FrfData(p, f, g[:, :, 0])
    with pytest.raises(DataError, match="sigma for every FRF"):
        fit_parameters(cfg, [FrfData(p, f, g, 0.1), FrfData(p, f, g)], FREE[:1])


def test_a_measurement_delay_is_fitted_not_absorbed(cfg):
    """Half a sample of a 5 kHz zero-order hold (0.1 ms, -10 deg at 290 Hz) on exact FRFs:
    with ``delay=True`` it comes back and the parameters stay within 0.1 %; without it the
    stiffnesses and inertias absorb it."""
    truth, f, pairings = _truth(cfg), _grid(cfg), _pairings(cfg)
    tau = 1e-4
    lag = np.exp(-2j * np.pi * f * tau)[:, None, None]
    data = [FrfData(p, f, g * lag) for p, g in zip(pairings, pairing_frf(truth, pairings, f),
                                                   strict=True)]
    true = np.array([get_value(truth, p) for p in FREE[:5]])
    res = fit_parameters(cfg, data, FREE[:5], delay=True, n_starts=2, search="starts")
    assert res.delay == pytest.approx(tau, rel=1e-4)
    assert res.delay_interval[0] <= res.delay <= res.delay_interval[1]
    assert np.max(np.abs(res.value / true - 1)) < 1e-3
    assert "delay [ms]" in res.table()
    blind = fit_parameters(cfg, data, FREE[:5], n_starts=2, search="starts")
    assert np.isnan(blind.delay_interval).all() and blind.delay == 0.0
    assert np.max(np.abs(blind.value / true - 1)) > 3 * np.max(np.abs(res.value / true - 1))


def test_intervals_widen_when_residuals_exceed_the_given_sigma(cfg):
    """A confidence band carries scatter, not bias: with a sigma 100 times smaller than the
    residuals' spread the noise scale (Birge ratio) is the residual rms, not 1."""
    truth, pairings = _truth(cfg), _pairings(cfg)
    f = np.geomspace(5.0, 350.0, 60)
    rng = np.random.default_rng(3)
    data = [FrfData(p, f, g * (1 + 0.05 * (rng.standard_normal(g.shape)
                                           + 1j * rng.standard_normal(g.shape))), 5e-4)
            for p, g in zip(pairings, pairing_frf(truth, pairings, f), strict=True)]
    res = fit_parameters(cfg, data, FREE[:5], n_starts=1, n_global=4, search="starts")
    assert res.noise_scale == pytest.approx(np.sqrt(np.mean(res.residual ** 2)), rel=0.05)
    assert res.noise_scale > 50
    true = np.array([get_value(truth, p) for p in FREE[:5]])
    assert np.mean((res.interval[:, 0] <= true) & (true <= res.interval[:, 1])) >= 0.8


def test_correlation_factor_is_the_long_run_variance_ratio():
    """White residuals: 1; AR(1) residuals with coefficient a: (1 + a)/(1 - a), the
    long-run to plain variance ratio (9 for a = 0.8), pooled over independent sequences."""
    from scipy.signal import lfilter

    from gbpipe.fit.estimate import correlation_factor
    rng = np.random.default_rng(0)
    labels = np.repeat(np.arange(40), 2000)
    white = rng.standard_normal(labels.size)
    assert correlation_factor(white, labels) == pytest.approx(1.0, abs=0.05)
    ar = np.concatenate([lfilter([1.0], [1.0, -0.8], rng.standard_normal(2000))
                         for _ in range(40)])
    assert correlation_factor(ar, labels) == pytest.approx(9.0, rel=0.1)


def test_band_jackknife_widens_intervals_for_model_error(cfg):
    """Data from a bench whose LSS shaft is 20 % stiffer than the model's, a parameter
    left fixed: the model error is not scatter, so the Fisher intervals miss truths that
    the delete-one-band jackknife's (never narrower) cover."""
    truth = with_values(_truth(cfg), {"bench.lss_shaft.stiffness": 3.6e8})
    pairings, f = _pairings(cfg), np.geomspace(5.0, 350.0, 120)
    data = [FrfData(p, f, g) for p, g in zip(pairings, pairing_frf(truth, pairings, f),
                                             strict=True)]
    res = fit_parameters(cfg, data, FREE[:5], n_starts=2, search="starts")
    jk = jackknife_intervals(res, data, 8)
    true = np.array([get_value(truth, p) for p in FREE[:5]])
    inside = [(r.interval[:, 0] <= true) & (true <= r.interval[:, 1]) for r in (res, jk)]
    assert np.all(jk.interval[:, 0] <= res.interval[:, 0] * (1 + 1e-12))
    assert np.all(jk.interval[:, 1] >= res.interval[:, 1] * (1 - 1e-12))
    assert inside[1].sum() > inside[0].sum()
    assert jk.interval_method == "jackknife over 8 bands"
    with pytest.raises(DataError, match="at least 3 bands"):
        jackknife_intervals(res, data, 2)
