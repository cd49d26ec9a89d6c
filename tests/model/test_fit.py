"""Physical-parameter fit (gbpipe.model.fit) on FRFs simulated from a perturbed bench."""

from __future__ import annotations

import numpy as np
import pytest

from gbpipe.errors import ConfigError, DataError
from gbpipe.model.fit import fit_parameters
from gbpipe.model.frf import Pairing, pairing_frf
from gbpipe.model.frf_data import FrfData
from gbpipe.model.keypath import get_value, parse_path, with_values

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
    ident = res.identified
    assert list(ident) == [True] * 5 + [False]
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
        res = fit_parameters(cfg, data, FREE[:5], n_starts=2, n_global=8, seed=seed)
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
