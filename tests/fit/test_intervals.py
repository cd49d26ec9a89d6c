"""95 % intervals of the physical fit: calibrated on exact data with scatter, and honest on
a Welch estimate once the fit compares it with the model seen through the window."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.signal import get_window
from scipy.stats import chi2

from gbpipe.config import load
from gbpipe.errors import DataError
from gbpipe.model.fit import fit_parameters
from gbpipe.model.fit_residuals import FrfResiduals, correlation_factor
from gbpipe.model.frf import Pairing, pairing_frf
from gbpipe.model.frf_data import FrfData, welch_kernel
from gbpipe.model.goodness import chi_square_test
from gbpipe.model.keypath import get_value, with_values
from gbpipe.model.parameters import FreeParameters
from tests.measured.shaftline_bench import record_data

ROOT = Path(__file__).resolve().parents[2]


def _hann_power_kernel(segment: float, n: int = 1024, pad: int = 256):
    """|W(ν)|² of a periodic Hann window of ``segment`` s by zero-padded FFT, normalised to
    unit sum, on ν [Hz] within ±200/segment (an independent computation of the kernel; its
    tail ∝ ν⁻⁶ beyond holds 0.1 % of m₄)."""
    w = get_window("hann", n)
    spec = np.abs(np.fft.fft(w, n * pad)) ** 2
    nu = np.fft.fftfreq(n * pad, segment / n)
    keep = np.abs(nu) < 200.0 / segment
    return nu[keep], spec[keep] / spec[keep].sum()


def test_the_welch_kernel_is_the_hann_windows_expected_estimate():
    """The three-node rule has the moments 1, m₂, m₄ of the Hann window's power kernel
    (computed from the window by FFT), and through it a lightly damped mode's FRF comes
    out as the kernel's convolution does: within 10 % of the resolution bias (which
    reaches 0.1 Np at the peak here) wherever that bias exceeds 1e-4 Np."""
    for segment in (0.5, 1.0, 4.0):
        nodes, weights = welch_kernel(segment)
        nu, k = _hann_power_kernel(segment)
        for power in (0, 2, 4):
            assert np.isclose(weights @ nodes ** power, k @ nu ** power, rtol=2e-3)
    segment, fn, zeta = 1.0, 33.0, 0.05        # half-power bandwidth 3.3 Hz
    nu, k = _hann_power_kernel(segment)

    def g(f):
        return 1.0 / (fn ** 2 - f ** 2 + 2j * zeta * fn * f)

    f = np.arange(20.0, 50.0, 0.7)
    exact = np.array([k @ g(fi - nu) for fi in f])
    rule = sum(w * g(f + x) for x, w in zip(*welch_kernel(segment), strict=True))
    bias = np.abs(np.log(exact / g(f)))
    assert bias.max() > 0.05
    err = np.abs(np.log(rule / exact))
    assert np.all(err[bias > 1e-4] <= 0.1 * bias[bias > 1e-4])


def test_a_welch_estimate_matches_the_model_seen_through_the_window():
    """The shaft line's reference-based Welch FRFs of a 30 s record of the nominal chain
    (tests/measured/shaftline_bench.py, 1 s Hann segments, modes of about 1 Hz bandwidth):
    at the truth, compared with the model seen through the window, the residuals pass
    the chi-square test against the estimate's own bounds with nearly uncorrelated
    residuals; compared with the model itself (segment not given) they fail it."""
    cfg = load(ROOT / "config" / "config.yaml", ROOT / "config" / "examples" / "shaftline.yaml")
    free = list(cfg["fit"]["free"])
    fp = FreeParameters.from_config(cfg, free)
    data = record_data(cfg, cfg, 5, 30.0)
    assert all(d.segment == cfg["identify"]["nonparametric"]["segment"] for d in data)
    plain = [FrfData(d.pairing, d.f_hz, d.frf, d.sigma) for d in data]
    verdicts = []
    for fit_data in (data, plain):
        prob = FrfResiduals(fp, fit_data, False)
        r = prob.residual(np.zeros(len(free)))
        c = correlation_factor(r, prob.sequences)
        verdicts.append((chi_square_test(r, 0, c, prob.groups, prob.frequency), c))
    (seen, c_seen), (bare, c_bare) = verdicts
    assert seen.status == "passed" and c_seen < 2.0
    assert bare.status == "poor" and bare.chi2 > 1.2 * seen.chi2


def test_intervals_cover_at_their_level_and_equal_the_profile_likelihoods(cfg):
    """Paper bench, three parameters, three pairings, exact FRFs of a perturbed truth
    with a 2 % complex log-normal scatter and that sigma given; 40 seeded draws, each
    fitted locally from the truth. The normalised errors ``ln(p̂/p)/σ`` have unit mean
    square (chi-square range of 120 values at 99.9 %) and the 95 % intervals miss at most
    as often as the binomial 99.9 % range allows; on the first draw each interval's ends
    are where the profile cost (the others refitted) has risen by χ²₁(0.95)/2 (times the
    noise scale squared the intervals use), to 20 %."""
    free = ["gearbox.housing.stiffness", "bench.coupling.stiffness", "gearbox.inertia[0]"]
    factors = np.array([0.8, 1.25, 1.15])
    truth = with_values(cfg, {p: get_value(cfg, p) * x for p, x in
                              zip(free, factors, strict=True)})
    pairings = [Pairing.from_config(p) for p in cfg["identify"]["pairings"]
                if p["name"] in ("Tdrv_to_wdrv", "Tdrn_to_wdrn", "Tdrv_to_Mdrv")]
    f = np.geomspace(5.0, 350.0, 60)
    exact = pairing_frf(truth, pairings, f)
    true = np.array([get_value(truth, p) for p in free])
    sigma, z = 0.02, []
    for draw in range(40):
        rng = np.random.default_rng(500 + draw)
        data = [FrfData(p, f, g * np.exp(sigma * (rng.standard_normal(g.shape)
                                                  + 1j * rng.standard_normal(g.shape))),
                        sigma) for p, g in zip(pairings, exact, strict=True)]
        res = fit_parameters(truth, data, free, n_starts=1, n_global=0, search="starts")
        assert res.identified.all()
        half = np.log(res.interval[:, 1] / res.value)
        z.append(np.log(res.value / true) / (half / 1.96))
        if draw == 0:
            # profile likelihood: one parameter held at an interval end, the others free
            prob = FrfResiduals(FreeParameters.from_config(truth, free), data, False)
            for i in range(len(free)):
                for end in res.interval[i]:
                    held = np.log(end / true[i])

                    def r_held(rest, i=i, held=held, prob=prob):
                        return prob.residual(np.insert(rest, i, held))
                    rest0 = np.delete(np.log(res.value / true), i)
                    rise = least_squares(r_held, rest0).cost - res.cost
                    # the interval's noise scale (≥ 1: max(1, rms)·√c) scales the level
                    level = chi2.ppf(0.95, 1) / 2 * res.noise_scale ** 2
                    # (not exactly quadratic: the housing stiffness, ±0.84 %, moves a
                    # lightly damped mode; its ends rose 0.89–1.16 of the level over draws)
                    assert abs(rise / level - 1) < 0.2
    z = np.array(z).ravel()
    lo, hi = chi2.ppf([0.0005, 0.9995], z.size) / z.size
    assert lo < np.mean(z ** 2) < hi
    assert np.sum(np.abs(z) > 1.96) <= 15        # binomial(120, 0.05): 99.9 % quantile


def test_a_welch_segment_is_checked_against_its_grid(cfg):
    """A segment that is not a positive length, or a fitted frequency within one
    resolution of 0 Hz (the kernel's lower node would reach DC), is refused by name."""
    pairing = Pairing.from_config(cfg["identify"]["pairings"][0])
    f = np.array([0.5, 2.0, 5.0])
    g = pairing_frf(cfg, [pairing], f)[0]
    for segment, words in ((-1.0, "positive length"), (1.0, "0.5 Hz is within one")):
        with pytest.raises(DataError, match=words):
            FrfData(pairing, f, g, 0.02, segment)
    g[0] = np.nan       # left out: accepted
    assert FrfData(pairing, f, g, 0.02, 1.0).segment == 1.0
