"""The global stage of the physical fit (gbpipe.fit.search) from a start far from
the truth: differential evolution over the bounds finds the minimum; and two starts that
agree in a wrong basin do not end the search."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gbpipe.config import load
from gbpipe.fit.estimate import fit_parameters
from gbpipe.fit.frf_data import FrfData
from gbpipe.fit.keypath import get_value, with_values
from gbpipe.fit.parameters import FreeParameters
from gbpipe.fit.residuals import FrfResiduals
from gbpipe.model.frf import Pairing, pairing_frf
from tests.measured.shaftline_bench import perturbed, record_data

FREE = ["gearbox.housing.stiffness", "bench.coupling.stiffness", "gearbox.stiffness[2]",
        "bench.motor_inertia.driver"]


def test_a_far_start_recovers_the_truth(cfg):
    """Truth: the paper bench; start: every free parameter x2 or /2 off it (not the
    nominal bench). Data: the truth's exact FRFs of three pairings with a 2 % log-normal
    scatter and that sigma given. The fit reaches the cost at the truth or lower, passes
    the chi-square test, and every parameter lies within twice its 95 % half-width
    (log scale) of the truth, and within 3 %."""
    pairings = [Pairing.from_config(p) for p in cfg["identify"]["pairings"]
                if p["name"] in ("Tdrv_to_wdrv", "Tdrn_to_wdrn", "Tdrv_to_Mdrv")]
    f = np.geomspace(5.0, 350.0, 70)
    sigma = 0.02
    rng = np.random.default_rng(11)
    data = [FrfData(p, f, g * np.exp(sigma * (rng.standard_normal(g.shape)
                                              + 1j * rng.standard_normal(g.shape))), sigma)
            for p, g in zip(pairings, pairing_frf(cfg, pairings, f), strict=True)]
    far = [2.0, 0.5, 0.5, 2.0]
    start = with_values(cfg, {p: get_value(cfg, p) * k for p, k in zip(FREE, far,
                                                                       strict=True)})
    res = fit_parameters(start, data, FREE, factor=3.0, seed=3, search="evolution")
    true = np.array([get_value(cfg, p) for p in FREE])
    r = FrfResiduals(FreeParameters.from_config(start, FREE), data, False).residual(
        -np.log(far))
    assert res.cost <= 0.5 * float(r @ r) * (1 + 1e-6)
    assert res.goodness.status == "passed" and res.identified.all()
    half = np.log(res.interval[:, 1] / res.value)
    assert np.all(np.abs(np.log(res.value / true)) < 2 * half)
    assert np.all(np.abs(res.value / true - 1) < 0.03)
    assert res.search == "starts + evolution"


def test_agreeing_starts_in_a_wrong_basin_do_not_end_the_search():
    """The shaft line of config/examples/shaftline.yaml with its three free parameters
    perturbed (seeds 0 and 1 of benchmarks/fit_chain.py, ``perturbed``: stable draws; on
    the H1 FRFs of the record sampled without anti-alias filter, an earlier draw of seed 0
    sent two starts into one wrong basin that passed the chi-square test). Data: the
    reference-based Welch FRFs of a 30 s record (tests/measured/shaftline_bench.py).
    With ``search="auto"`` the fit ends at
    the cost at the truth or below (not above it by more than the chi-square's own
    spread would excuse) and no parameter it calls identified lies outside 10 % of the
    truth."""
    root = Path(__file__).resolve().parents[2]
    cfg = load(root / "config" / "config.yaml", root / "config" / "examples" / "shaftline.yaml")
    free = list(cfg["fit"]["free"])
    fp = FreeParameters.from_config(cfg, free)
    for seed in (0, 1):
        truth, factors = perturbed(cfg, free, np.random.default_rng(seed))
        data = record_data(cfg, truth, seed, 30.0)
        r = FrfResiduals(fp, data, False).residual(np.log(factors))
        res = fit_parameters(cfg, data, free, seed=seed, n_starts=cfg["fit"]["starts"],
                             bounds=cfg["fit"]["bounds"], factor=cfg["fit"]["factor"])
        assert res.search == "starts + evolution"
        assert res.cost <= 0.5 * float(r @ r) * 1.01
        true = np.array([get_value(truth, p) for p in free])
        # nothing identified only when the fit says poor
        assert res.identified.any() or res.goodness.status == "poor"
        assert np.all(np.abs(res.value[res.identified] / true[res.identified] - 1) < 0.10)
