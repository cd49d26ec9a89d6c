"""Tests of gbpipe.harmonics.regression against hand-built records
(:mod:`removal_signals`): known modulated harmonics on a known sweep, amplitudes exactly
in the basis, and white noise whose least-squares capture is known in closed form."""

from __future__ import annotations

import numpy as np
import pytest
from removal_signals import FAMILIES, db, inner, sweep
from scipy.interpolate import BSpline

from gbpipe.harmonics.regression import AmplitudeBasis, residual_regression


@pytest.fixture(scope="module")
def clean():
    return sweep(noise=0.0)


def test_modulated_harmonics_removed_by_60_db(clean):
    r = residual_regression(clean["x"], clean["fs"], clean["pulses"], FAMILIES,
                            knot_spacing=1.0)
    m = inner(clean["t"], clean["pulses"], 0.0)
    assert db(np.mean(clean["h"][m] ** 2), np.mean(r[m] ** 2)) >= 60.0


def test_amplitudes_in_the_legendre_basis_are_removed_exactly(clean):
    # a(t) a cubic polynomial, phase fixed: exactly representable, so what stays is the
    # error of the angle interpolated between pulses (~1e-5 rad: -90 dB at order 5)
    t, th = clean["t"], clean["theta"]
    u = (t - 10.0) / 10.0
    x = (1 + 0.5 * u - 0.3 * u**3) * np.cos(3 * th + 0.2) + (0.4 - 0.2 * u**2) * np.sin(
        5.3569 * th)
    r = residual_regression(x, clean["fs"], clean["pulses"], FAMILIES, basis="legendre",
                            degree=3)
    m = inner(t, clean["pulses"], 0.0)
    assert db(np.mean(x[m] ** 2), np.mean(r[m] ** 2)) >= 85.0


def test_white_noise_capture_is_the_parameter_count():
    # Least squares on p harmonic columns takes p * s2 of white noise (its projection),
    # i.e. a fraction p / N of the record's noise power; the slow-mean columns are fitted
    # but not subtracted.
    sw = sweep(noise=0.5)
    span = inner(sw["t"], sw["pulses"], 0.0)
    t = sw["t"][span]
    n_basis = AmplitudeBasis(t[0], t[-1], "bspline", 1.0, 3).size
    p = n_basis * 2 * sum(len(v) for v in FAMILIES.values())
    r = residual_regression(sw["x"], sw["fs"], sw["pulses"], FAMILIES, knot_spacing=1.0)
    err = np.sum((r - sw["res"])[span] ** 2)
    assert db(err, p * 0.25) == pytest.approx(0.0, abs=0.5)


def test_large_mean_and_trend_do_not_leak(clean):
    trend = 1.0e4 + 50.0 * clean["t"]
    r = residual_regression(clean["h"] + trend, clean["fs"], clean["pulses"], FAMILIES)
    m = inner(clean["t"], clean["pulses"], 0.0)
    assert db(np.mean(clean["h"][m] ** 2), np.mean((r - trend)[m] ** 2)) >= 60.0


def test_bspline_basis_is_a_partition_of_unity():
    b = AmplitudeBasis(0.0, 10.0, "bspline", 1.0, 3)
    t = np.linspace(2.0, 2.99, 50)
    vals, first = b.values(t)
    np.testing.assert_allclose(vals.sum(axis=1), 1.0, atol=1e-12)
    assert first == 2 and b.size == 13


@pytest.mark.parametrize("seed", range(4))
def test_unfollowed_is_the_least_squares_misfit(seed):
    # against an independent least-squares fit in the same basis (numpy's lstsq on the
    # dense design matrix), over random knot spacings and slowly wandering phases
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0.0, 12.0, 3000))
    y = np.cumsum(rng.standard_normal(t.size)) * 1e-3 + 0.3 * np.sin(rng.uniform(0.2, 2) * t)
    b = AmplitudeBasis(float(t[0]), float(t[-1]), "bspline", float(rng.uniform(0.5, 3.0)), 3)
    design = BSpline.design_matrix(t, b.knots, 3).toarray()
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    np.testing.assert_allclose(b.unfollowed(t, y), y - design @ coef, rtol=0, atol=1e-11)


def test_bad_arguments(clean):
    with pytest.raises(ValueError, match="basis"):
        residual_regression(clean["x"], clean["fs"], clean["pulses"], FAMILIES,
                            basis="fourier")
    with pytest.raises(ValueError, match="knot_spacing"):
        residual_regression(clean["x"], clean["fs"], clean["pulses"], FAMILIES,
                            knot_spacing=0.0)


def test_per_family_knot_spacing_captures_each_groups_parameter_count():
    # Families fitted in groups of their own knot spacing: the white noise taken is the
    # sum of each group's harmonic columns (their subspaces are nearly orthogonal), so a
    # coarser basis for one family takes proportionally less of the broadband part.
    # Expected p * s2, chi-square with p degrees of freedom: 4 records hold ~600 (sd 6 %).
    spacing = {"default": 1.0, next(iter(FAMILIES)): 2.0}
    taken = expected = 0.0
    for seed in range(4):
        sw = sweep(noise=0.5, seed=seed)
        span = inner(sw["t"], sw["pulses"], 0.0)
        t = sw["t"][span]
        expected += 0.25 * sum(
            AmplitudeBasis(t[0], t[-1], "bspline", spacing.get(k, 1.0), 3).size * 2 * len(v)
            for k, v in FAMILIES.items())
        # the method is linear: run on the noise alone, what it takes is exactly the capture
        r = residual_regression(sw["res"], sw["fs"], sw["pulses"], FAMILIES,
                                knot_spacing=spacing)
        taken += np.sum((r - sw["res"])[span] ** 2)
    assert db(taken, expected) == pytest.approx(0.0, abs=0.5)


@pytest.mark.parametrize("spacing, match", [({"nope": 1.0, "default": 1.0}, "not families"),
                                            ({next(iter(FAMILIES)): 1.0}, "no entry")])
def test_per_family_knot_spacing_is_checked(clean, spacing, match):
    with pytest.raises(ValueError, match=match):
        residual_regression(clean["x"], clean["fs"], clean["pulses"], FAMILIES,
                            knot_spacing=spacing)
