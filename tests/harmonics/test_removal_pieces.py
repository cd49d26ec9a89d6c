"""Tests of the VKF and regression removals of a long record in overlapping pieces: their
margins against independent computations (the poles of the envelope filter by
``numpy.roots``, the banded solve's own impulse response, scipy's least-squares spline),
and the pieces' residual against the whole record's within the bound each margin gives."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import make_lsq_spline

from gbpipe.harmonics.amplitude_basis import AmplitudeBasis
from gbpipe.harmonics.pieces import by_pieces
from gbpipe.harmonics.regression import residual_regression
from gbpipe.harmonics.vkf import EnvelopeFilter, envelope_margin, residual_vkf, structural_weight

FS = 2000.0  # Hz
ORDERS = {"a": [1.0, 2.0], "b": [4.5]}  # orders 1, 2, 4.5: 10-45 Hz, > 10 bandwidths apart


def _record(n: int, seed: int, noise: float = 0.3):
    """A shaft near 10 rev/s whose speed wanders, the three orders with slowly
    modulated amplitudes (their sum: ``h``), white noise of rms ``noise``; pulses
    (1 per rev) from the true angle."""
    t = np.arange(n) / FS
    rng = np.random.default_rng(seed)
    omega = 2 * np.pi * (10 + 0.5 * np.sin(2 * np.pi * t / 40))  # rad/s
    theta = np.cumsum(omega) / FS
    h = sum((1 + 0.3 * np.sin(2 * np.pi * t / (7 + k))) * np.cos(o * theta + k)
            for k, o in enumerate([1.0, 2.0, 4.5]))
    x = h + noise * rng.standard_normal(n)
    pulses = np.interp(2 * np.pi * np.arange(1, int(theta[-1] / (2 * np.pi))), theta, t)
    return t, h, x, pulses


@pytest.mark.parametrize("s", [1, 2])
@pytest.mark.parametrize("bandwidth", [2.0, 20.0])
def test_envelope_margin_is_the_slowest_pole_of_the_filter(s, bandwidth):
    # numpy.roots of z^s + (-1)^s w (z - 1)^(2s) (accurate at these moderate weights):
    # the largest modulus inside the unit circle sets the samples to a decay of 1e-6
    w = float(structural_weight(bandwidth, FS, s))
    poly = (-1) ** s * w * np.poly1d([1.0, -1.0]) ** (2 * s) + np.poly1d([1.0] + [0.0] * s)
    roots = np.roots(poly.coeffs)
    rho = np.abs(roots[np.abs(roots) < 1]).max()
    assert envelope_margin(w, s, 1e-6) == pytest.approx(np.log(1e-6) / np.log(rho), abs=1.0)


def test_the_banded_solve_forgets_a_cut_within_the_margin():
    # the response of (1) to a unit impulse (a change at one sample, as a cut makes)
    # has fallen to the margin's decay at the margin's distance, and not much before
    n, s, decay = 40_000, 2, 1e-4
    w = float(structural_weight(2.0, FS, s))
    filt = EnvelopeFilter(np.full(n - s, w), n, s)
    e = np.zeros((n, 1))
    e[n // 2] = 1.0
    g = np.abs(filt.solve(e)[:, 0])
    m = envelope_margin(w, s, decay)
    # beyond the margin: below the decay (the pole pair's oscillation gives at most a
    # factor 1 / sin of its angle, ~1.4 for s = 2); at a third of it, well above it
    assert g[n // 2 + m:n // 2 + 2 * m].max() <= 2 * decay * g.max()
    assert g[n // 2 + m // 3:n // 2 + m // 2].max() > 10 * decay * g.max()


def test_vkf_in_pieces_equals_the_whole_record_within_the_margins_decay():
    # the same system on every piece, truncated at its ends: away from the record's ends
    # the pieces' residual differs from the whole record's by at most the tolerance the
    # margin is derived from (per envelope: 3 orders and the mean), and a margin of a
    # tenth of it leaves far more -- the bound tells the margins apart
    n, tol, piece = 120_000, 1e-6, 20_000
    t, h, x, pulses = _record(n, seed=4)
    kw = dict(bandwidth=2.0, tol=tol, max_iter=200)
    whole = residual_vkf(x, FS, pulses, ORDERS, **kw, piece=n)
    pieces = residual_vkf(x, FS, pulses, ORDERS, **kw, piece=piece)
    inner = (t > 1.0) & (t < t[-1] - 1.0)
    bound = 4 * tol * np.abs(h).max()
    assert np.abs(pieces - whole)[inner].max() <= bound

    short = envelope_margin(float(structural_weight(2.0, FS, 2)), 2, tol) // 10

    def vkf(part, p, start):
        return residual_vkf(part, FS, p, ORDERS, **kw, t0=start, piece=part.size)
    cut = by_pieces(x, FS, pulses, short, vkf, piece)
    assert np.abs(cut - whole)[inner].max() > 10 * bound


def test_spline_reach_is_the_decay_of_scipys_least_squares_spline():
    # a unit spike fitted by scipy's least-squares cubic spline (uniform knots, many
    # samples per knot): its fit k knots away falls as |lambda|^k; at the reach of a
    # 1e-4 decay it is at most that, three knots before it well above it
    basis = AmplitudeBasis(0.0, 1.0, "bspline", 1.0, 3)
    k = basis.reach(1e-4)
    t = np.linspace(0.0, 60.0, 60 * 200 + 1)
    knots = np.r_[[0.0] * 3, np.arange(61.0), [60.0] * 3]
    y = np.zeros_like(t)
    y[t.size // 2] = 1.0
    fit = np.abs(make_lsq_spline(t, y, knots, 3)(t))
    centre = fit[t.size // 2]
    at = np.abs(t - 30.0)
    assert fit[(at >= k) & (at < k + 1)].max() <= 2e-4 * centre
    assert fit[(at >= k - 3) & (at < k - 2)].max() > 2e-4 * centre


def test_regression_in_pieces_removes_as_the_whole_record_within_the_noise_it_fits():
    # pieces have their own knots (uniform over the piece), so they fit the noise near
    # each order with other functions than the whole record: each fit takes rms
    # sigma sqrt(P / N) of it (P / N: (2 orders + 1) functions per knot interval of
    # h fs samples), two fits differ by at most twice that; the lines go as far down
    n, h_knot, piece, sigma = 250_000, 0.5, 60_000, 0.3
    t, h, x, pulses = _record(n, seed=5, noise=sigma)
    whole = residual_regression(x, FS, pulses, ORDERS, knot_spacing=h_knot, piece=n)
    pieces = residual_regression(x, FS, pulses, ORDERS, knot_spacing=h_knot, piece=piece)
    inner = (t > 1.0) & (t < t[-1] - 1.0)
    per_sample = (2 * 3 + 1) / (h_knot * FS)
    diff = (pieces - whole)[inner]
    assert np.sqrt(np.mean(diff ** 2)) <= 2 * sigma * np.sqrt(per_sample)
    # both leave the noise: what is left of the lines is within the same fitted noise
    for r in (whole, pieces):
        left = (r - (x - h))[inner]
        assert np.sqrt(np.mean(left ** 2)) <= 1.5 * sigma * np.sqrt(per_sample)
    # channels as columns (time first) are cut as one record: each column's residual is
    # the one it has alone, and the fit is linear (twice the record, twice the residual)
    two = residual_regression(np.column_stack([x, 2 * x]), FS, pulses, ORDERS,
                              knot_spacing=h_knot, piece=piece)
    np.testing.assert_allclose(two[:, 0], pieces, rtol=0, atol=1e-9 * np.abs(x).max())
    np.testing.assert_allclose(two[:, 1], 2 * pieces, rtol=0, atol=1e-9 * np.abs(x).max())


def test_regression_over_its_record_gives_the_residual_a_new_array_holds():
    # overwrite_x: the residual replaces the record, in pieces (whose margins the next
    # piece reads before they are written) and in one call, with per-family knots (each
    # family group after the first works on its own array) -- the same numbers as a call
    # that leaves the record alone
    # the channels of one record, (n, channels), and of two records of one angle, (records,
    # n, channels), whose pieces are cut along the second axis (a strided view)
    n, piece = 250_000, 60_000
    _, _, x, pulses = _record(n, seed=6, noise=0.3)
    channels = np.column_stack([x, 0.5 * x[::-1]])
    spacing = {"a": 0.5, "b": 1.0}
    for given in (channels, np.stack([channels, -2.0 * channels])):
        for cut in (piece, n):
            alone = residual_regression(given, FS, pulses, ORDERS, knot_spacing=spacing,
                                        piece=cut)
            record = given.copy()
            out = residual_regression(record, FS, pulses, ORDERS, knot_spacing=spacing,
                                      piece=cut, overwrite_x=True)
            assert np.shares_memory(out, record)
            np.testing.assert_array_equal(out, alone)
    np.testing.assert_array_equal(channels[:, 0], x)  # the default leaves it alone
