"""Nonparametric FRF (``gbpipe.sysid.welch_frf``) against systems with a known FRF.

The plants are discrete transfer functions simulated with ``scipy.signal.lfilter`` and
their true FRF is ``scipy.signal.freqz``: nothing here shares code with the estimator.
The coverage tests count how often the true FRF lies inside the 95 % confidence circle
over many seeds; a calibrated band holds it at about 95 % of the (seed, frequency) pairs.
Measured values (60 seeds, printed with ``pytest -s``): see docs/sysid.md.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as sig

from gbpipe.errors import ConfigError, DataError
from gbpipe.sysid import (
    NonparametricFRF,
    coherent_band,
    equivalent_averages,
    welch_frf,
)

FS = 100.0        # Hz
NPERSEG = 128     # samples: 0.78 Hz resolution
N = 20 * NPERSEG  # samples: 39 windows at 50 % overlap
SEEDS = range(60)
# plant P(z) = (0.5 z^-1 + 0.3 z^-2) / (1 - 2·0.8 cos(π/4) z^-1 + 0.64 z^-2):
# strictly proper (a loop around it is causal), resonance near fs/8 = 12.5 Hz
B = np.array([0.0, 0.5, 0.3])
A = np.poly([0.8 * np.exp(1j * np.pi / 4), 0.8 * np.exp(-1j * np.pi / 4)]).real
K_P = 0.5         # proportional feedback gain [input unit per output unit]


def true_frf(b, a, freq):
    return sig.freqz(b, a, worN=freq, fs=FS)[1]


def radius(est: NonparametricFRF) -> np.ndarray:
    """Radius of the confidence circle, recovered from the magnitude bounds."""
    return est.magnitude_upper - np.abs(est.frf)


def open_loop(seed: int, noise: float = 0.5):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(N)
    return u, sig.lfilter(B, A, u) + noise * rng.standard_normal(N)


def closed_loop(seed: int):
    """u = K_P (r - y), y = P u + v with coloured v: the noise enters inside the loop."""
    rng = np.random.default_rng(seed)
    r = 3.0 * rng.standard_normal(N)
    v = sig.lfilter([1.0], [1.0, -0.5], rng.standard_normal(N))
    den = np.polyadd(A, K_P * B)
    assert np.all(np.abs(np.roots(den)) < 1.0)             # the loop is stable
    u = sig.lfilter(K_P * A, den, r) - sig.lfilter(K_P * A, den, v)
    y = sig.lfilter(K_P * B, den, r) + sig.lfilter(A, den, v)
    return r, u, y


def coverage_and_bias(make, **kwargs):
    """Fraction of (seed, frequency) pairs inside the circle; median relative bias."""
    inside, estimates = [], []
    for seed in SEEDS:
        *ref, u, y = make(seed)
        est = welch_frf(u, y, FS, nperseg=NPERSEG, reference=ref[0] if ref else None,
                        **kwargs)
        h = true_frf(B, A, est.frequency)
        inside.append(np.abs(est.frf[:, 0, 0] - h) <= radius(est)[:, 0, 0])
        estimates.append(est.frf[:, 0, 0])
    bias = np.abs(np.mean(estimates, axis=0) - h) / np.abs(h)
    return float(np.mean(inside)), float(np.median(bias))


def test_h1_matches_scipy_welch_and_holds_the_true_frf():
    u, y = open_loop(0)
    est = welch_frf(u, y, FS, nperseg=NPERSEG)
    # independent spectra: scipy's own csd / welch / coherence framing
    f, s_uy = sig.csd(u, y, fs=FS, nperseg=NPERSEG)
    _, s_uu = sig.welch(u, fs=FS, nperseg=NPERSEG)
    _, coh = sig.coherence(u, y, fs=FS, nperseg=NPERSEG)
    np.testing.assert_allclose(est.frequency, f)
    np.testing.assert_allclose(est.frf[:, 0, 0], s_uy / s_uu, rtol=1e-10)
    np.testing.assert_allclose(est.coherence[:, 0, 0], coh, rtol=1e-10)
    h = np.abs(true_frf(B, A, f))
    inside = (est.magnitude_lower[:, 0, 0] <= h) & (h <= est.magnitude_upper[:, 0, 0])
    assert inside.mean() >= 0.9
    # the phase interval holds the true phase where the circle does
    dphase = np.angle(est.frf[:, 0, 0] / true_frf(B, A, f))
    circle = np.abs(est.frf[:, 0, 0] - true_frf(B, A, f)) <= radius(est)[:, 0, 0]
    assert np.all(np.abs(dphase[circle]) <= est.phase_halfwidth[circle, 0, 0] + 1e-12)
    assert est.frf.shape == est.coherence.shape == (NPERSEG // 2 + 1, 1, 1)
    assert est.level == 0.95 and est.estimator == "h1"


@pytest.mark.parametrize("level, low, high", [(0.95, 0.90, 0.99), (0.8, 0.75, 0.85)])
def test_h1_band_is_calibrated_over_seeds(level, low, high):
    cover, bias = coverage_and_bias(open_loop, level=level)
    print(f"h1 open loop, level {level}: coverage {cover:.3f}, median relative bias "
          f"{bias:.4f}")
    assert low <= cover <= high
    assert bias < 0.03


def test_closed_loop_h1_is_biased_reference_is_not():
    cover_ref, bias_ref = coverage_and_bias(closed_loop, estimator="reference")
    cover_h1, bias_h1 = coverage_and_bias(lambda s: closed_loop(s)[1:])
    print(f"closed loop: reference coverage {cover_ref:.3f}, bias {bias_ref:.4f}; "
          f"h1 coverage {cover_h1:.3f}, bias {bias_h1:.4f}")
    assert 0.90 <= cover_ref <= 0.99
    assert bias_ref < 0.05
    # the noise fed back through the controller pulls H1 towards -1/K_P
    assert bias_h1 > 0.3 and cover_h1 < 0.6


def test_long_record_is_transformed_in_blocks_with_the_same_spectra():
    # 1199 windows: more than one block of ShortTimeFFT slices
    rng = np.random.default_rng(4)
    u = rng.standard_normal(600 * 64)
    y = sig.lfilter(B, A, u) + rng.standard_normal(u.size)
    est = welch_frf(u, y, FS, nperseg=64, detrend="linear")
    s_uy = sig.csd(u, y, nperseg=64, detrend="linear")[1]
    s_uu = sig.welch(u, nperseg=64, detrend="linear")[1]
    np.testing.assert_allclose(est.frf[:, 0, 0], s_uy / s_uu, rtol=1e-10)


def test_reference_with_more_channels_than_inputs():
    # set-point r1 and a dither r2 added to the controller output: both are instruments
    inside = []
    for seed in range(10):
        rng = np.random.default_rng(200 + seed)
        r = rng.standard_normal((N, 2)) * [3.0, 1.0]
        v = sig.lfilter([1.0], [1.0, -0.5], rng.standard_normal(N))
        den = np.polyadd(A, K_P * B)
        drive = K_P * r[:, 0] + r[:, 1]                      # u = K_P (r1 - y) + r2
        u = sig.lfilter(A, den, drive) - sig.lfilter(K_P * A, den, v)
        y = sig.lfilter(B, den, drive) + sig.lfilter(A, den, v)
        est = welch_frf(u, y, FS, nperseg=NPERSEG, reference=r, estimator="reference")
        h = true_frf(B, A, est.frequency)
        inside.append(np.abs(est.frf[:, 0, 0] - h) <= radius(est)[:, 0, 0])
    print(f"closed loop, 2 references: coverage {np.mean(inside):.3f}")
    assert 0.90 <= np.mean(inside) <= 0.99


def test_hv_removes_the_input_noise_bias_of_h1():
    # noise at the same 20 % of the rms on both measured channels (what Hv assumes)
    h1, hv = [], []
    for seed in range(20):
        rng = np.random.default_rng(seed)
        u0 = rng.standard_normal(8 * N)
        y0 = sig.lfilter(B, A, u0)
        u = u0 + 0.2 * u0.std() * rng.standard_normal(u0.size)
        y = y0 + 0.2 * y0.std() * rng.standard_normal(y0.size)
        h1.append(welch_frf(u, y, FS, nperseg=NPERSEG).frf[:, 0, 0])
        hv.append(welch_frf(u, y, FS, nperseg=NPERSEG, estimator="hv").frf[:, 0, 0])
    h = true_frf(B, A, np.fft.rfftfreq(NPERSEG, 1 / FS))
    gain_h1 = np.median(np.abs(np.mean(h1, axis=0) / h))
    gain_hv = np.median(np.abs(np.mean(hv, axis=0) / h))
    assert gain_h1 == pytest.approx(1 / 1.04, abs=0.01)    # S_uu / (S_uu + 0.04 S_uu)
    assert gain_hv == pytest.approx(1.0, abs=0.01)


def test_mimo_2x2_h1_against_true_frf():
    # y_a = Σ_i P_ai u_i + noise; true FRF of each element from freqz
    plants = [[(B, A), ([0.0, 0.4], [1.0, -0.7])],
              [([0.0, 0.2, 0.1], [1.0, -0.5, 0.3]), ([0.0, 1.0], [1.0, 0.6])]]
    inside, estimates = [], []
    for seed in range(30):
        rng = np.random.default_rng(100 + seed)
        u = rng.standard_normal((N, 2))
        y = 0.3 * rng.standard_normal((N, 2))
        for a in range(2):
            for i in range(2):
                y[:, a] += sig.lfilter(*plants[a][i], u[:, i])
        est = welch_frf(u, y, FS, nperseg=NPERSEG)
        h = np.moveaxis(np.array([[true_frf(*plants[a][i], est.frequency) for i in range(2)]
                                  for a in range(2)]), -1, 0)        # (F, ny, nu)
        inside.append(np.abs(est.frf - h) <= radius(est))
        estimates.append(est.frf)
    bias = np.abs(np.mean(estimates, axis=0) - h) / np.abs(h)
    print(f"MIMO 2x2 h1: coverage {np.mean(inside):.3f}, median bias of the 30-seed mean "
          f"{np.median(bias):.4f}")
    assert est.frf.shape == (NPERSEG // 2 + 1, 2, 2)
    assert 0.90 <= np.mean(inside) <= 0.99
    assert np.median(bias) < 0.04


@pytest.mark.parametrize("window, rho1", [("hann", 1 / 36), ("boxcar", 1 / 4)])
def test_overlap_gives_welch_equivalent_averages(window, rho1):
    # 50 % overlap: only neighbouring windows overlap; hand-computed correlation rho(1):
    # Hann  Σ w_n w_{n+M/2} = M/16, Σ w² = 3M/8  -> (1/6)² ; boxcar (M/2)² / M² = 1/4
    n_seg = 10
    expected = n_seg / (1 + 2 * (1 - 1 / n_seg) * rho1)
    assert equivalent_averages(window, 64, 32, n_seg) == pytest.approx(expected, rel=1e-12)
    assert equivalent_averages(window, 64, 0, n_seg) == pytest.approx(n_seg, rel=1e-12)
    u, y = open_loop(1)
    est = welch_frf(u, y, FS, nperseg=64, window=window)     # (2560 - 64)/32 + 1 = 79
    assert est.n_averages == pytest.approx(79 / (1 + 2 * (1 - 1 / 79) * rho1), rel=1e-12)


def test_records_are_pooled_by_their_number_of_windows():
    u, y = open_loop(2)
    cut = 1000                                               # 14 and 23 windows
    est = welch_frf([u[:cut], u[cut:]], [y[:cut], y[cut:]], FS, nperseg=NPERSEG)
    spectra = [(sig.csd(u[s], y[s], nperseg=NPERSEG)[1], sig.welch(u[s], nperseg=NPERSEG)[1],
                (len(u[s]) - NPERSEG) // (NPERSEG // 2) + 1)
               for s in (slice(0, cut), slice(cut, None))]
    s_uy = sum(k * c for c, _, k in spectra)
    s_uu = sum(k * p for _, p, k in spectra)
    np.testing.assert_allclose(est.frf[:, 0, 0], s_uy / s_uu, rtol=1e-10)
    assert est.n_averages == pytest.approx(
        equivalent_averages("hann", NPERSEG, NPERSEG // 2, 14)
        + equivalent_averages("hann", NPERSEG, NPERSEG // 2, 23), rel=1e-12)


def test_coherent_band_on_hand_built_coherence():
    freq = np.arange(8.0)                                    # Hz
    coh = np.array([0.2, 0.95, 0.96, 0.5, 0.91, 0.92, 0.93, 0.1])[:, None, None]
    est = NonparametricFRF(freq, np.ones((8, 1, 1), complex), coh, 10.0, coh, coh, coh,
                           0.95, "h1")
    band = coherent_band(est, 0.9)
    np.testing.assert_array_equal(band.mask[:, 0, 0], coh[:, 0, 0] >= 0.9)
    assert (band.f_low[0, 0], band.f_high[0, 0]) == (4.0, 6.0)   # the longest run
    assert np.isnan(coherent_band(est, 0.99).f_low[0, 0])


@pytest.mark.parametrize("kwargs, error, names", [
    (dict(u=np.r_[np.ones(300), np.nan, np.ones(299)]), DataError, ["u", "sample 300"]),
    (dict(y=np.ones(599)), DataError, ["y", "599 samples"]),
    (dict(u=np.ones(100), y=np.ones(100)), DataError, ["u", "nperseg=128"]),
    (dict(u=np.ones(128), y=np.ones(128)), DataError, ["u", "window"]),
    (dict(estimator="h2"), ConfigError, ["estimator", "h1"]),
    (dict(estimator="reference"), ConfigError, ["reference"]),
    (dict(y=[np.ones(600), np.ones(600)]), DataError, ["y", "record"]),
    (dict(u=np.ones((600, 2)), y=np.ones((600, 1)), estimator="hv"), ConfigError, ["hv"]),
    (dict(u=np.ones((600, 2)), estimator="reference", reference=np.ones(600)),
     DataError, ["reference", "channel"]),
    (dict(noverlap=128), ConfigError, ["noverlap"]),
    (dict(level=95), ConfigError, ["level"]),
])
def test_bad_inputs_are_refused_with_the_argument_named(kwargs, error, names):
    rng = np.random.default_rng(3)
    args = dict(u=rng.standard_normal(600), y=rng.standard_normal(600)) | kwargs
    with pytest.raises(error) as info:
        welch_frf(args.pop("u"), args.pop("y"), FS, nperseg=NPERSEG, **args)
    for name in names:
        assert name in str(info.value)
    assert isinstance(info.value, ValueError)
