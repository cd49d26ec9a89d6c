"""Tests of gbpipe.harmonics.drs against hand-built records (:mod:`removal_signals`):
the Wiener gain SNR / (1 + SNR) of a line of known amplitude in white noise of known
power, and the removal of known modulated harmonics on a known sweep."""

from __future__ import annotations

import numpy as np
import pytest
from harmonic_sweeps import line_power
from removal_signals import FAMILIES, db, inner, sweep

from gbpipe.harmonics.drs import drs_gain, residual_drs


@pytest.mark.parametrize("sigma", [2.0, 4.0])
def test_gain_at_a_line_is_the_wiener_gain(sigma):
    # Line A cos(3 theta) on a Welch bin, white noise sigma, Hann segments of N points:
    # bin SNR = (A/2 sum w)^2 / (sigma^2 sum w^2) = A^2 N / (6 sigma^2); the delayed
    # copy shares no noise sample, so |gamma| = SNR / (1 + SNR).
    rng = np.random.default_rng(1)
    spr, seg = 48, 16
    theta = 2 * np.pi * np.arange(300 * spr) / spr
    xa = np.cos(3 * theta) + sigma * rng.standard_normal(theta.size)
    orders, gain = drs_gain(xa, spr, seg, seg + 4, 0.75, "hann")
    snr = seg * spr / (6 * sigma**2)
    assert gain[np.argmin(np.abs(orders - 3))] == pytest.approx(snr / (1 + snr), abs=0.02)
    # noise-only bins: only the estimator's bias ~ 1 / sqrt(number of segments) stays
    assert np.median(gain) < 0.2


def test_families_removed_and_noise_kept():
    sw = sweep(noise=0.1)
    r = residual_drs(sw["x"], sw["fs"], sw["pulses"], FAMILIES, segment_revs=8)
    m = inner(sw["t"], sw["pulses"], 1.0)
    err = r - sw["res"]
    for orders in FAMILIES.values():  # exact projection on the true angle's sinusoids
        assert db(line_power(sw["h"], sw["theta"], orders, m),
                  line_power(err, sw["theta"], orders, m)) >= 30.0
    # the gain is masked to the families' bands: the noise elsewhere is untouched
    assert db(np.mean(err[m] ** 2), np.mean(sw["res"][m] ** 2)) <= -10.0


def test_delay_must_exceed_the_segment():
    sw = sweep(noise=0.1)
    with pytest.raises(ValueError, match="delay_revs"):
        residual_drs(sw["x"], sw["fs"], sw["pulses"], FAMILIES, segment_revs=8,
                     delay_revs=4)
