"""Tests of gbpipe.harmonics.separation on signals whose dB values are computed by hand:
scaled copies of known parts (exact ratios) and a known tone in known white noise."""

from __future__ import annotations

import numpy as np
import pytest
from removal_signals import FAMILIES, sweep

from gbpipe.harmonics.separation import frequency_bands, separation_metrics

MODES = [62.0, 100.0]


@pytest.fixture(scope="module")
def sw():
    s = sweep(noise=0.0)
    s["n"] = 0.3 * np.random.default_rng(11).standard_normal(s["t"].size)
    return s


def metrics(sw, residual, **kw):
    return separation_metrics(residual, sw["n"], sw["h"], sw["fs"], sw["pulses"], FAMILIES,
                              MODES, rpm_bins=4, f_max=400.0, **kw)


def test_attenuation_is_exact_for_a_scaled_leftover(sw):
    # residual - random = 1e-3 harmonic: -60 dB of every family in every bin, exactly;
    # the same method on the harmonic alone left 1e-2 of it: 40 dB
    ds = metrics(sw, sw["n"] + 1e-3 * sw["h"], harmonic_residual=1e-2 * sw["h"])
    np.testing.assert_allclose(ds.attenuation_db.values, 60.0, atol=1e-6)
    np.testing.assert_allclose(ds.leftover_db.values, 40.0, atol=1e-6)


def test_distortion_and_change_of_a_scaled_random_part(sw):
    # residual = 1.1 random: the error is 0.1 random in every band (-20 dB) and the band
    # level is up by 20 log10(1.1) = 0.828 dB, exactly
    ds = metrics(sw, 1.1 * sw["n"])
    np.testing.assert_allclose(ds.distortion_db.values, -20.0, atol=1e-9)
    np.testing.assert_allclose(ds.change_db.values, 20 * np.log10(1.1), atol=1e-9)
    assert "leftover_db" not in ds


def test_a_tone_shows_only_in_its_band_at_its_level(sw):
    # random part: white noise plus a tone B sin(2 pi 98 t); error: a tone A sin(2 pi 100 t).
    # Both tones fall in the 100 +- 4 Hz band with the same window spread, so there the
    # distortion is 20 log10(A / B) (+ the noise's share of the band, 0.0007 dB here);
    # the other bands hold no error but the tone's window leakage (< -60 dB).
    a, b = 0.1, 1.0
    rnd = sw["n"] + b * np.sin(2 * np.pi * 98.0 * sw["t"])
    err = a * np.sin(2 * np.pi * 100.0 * sw["t"])
    ds = separation_metrics(rnd + err, rnd, sw["h"], sw["fs"], sw["pulses"], FAMILIES,
                            MODES, rpm_bins=4, f_max=400.0)
    noise_share = 2 * 0.09 * 8.5 / sw["fs"] / (b**2 / 2)  # 17 bins of 0.5 Hz, white noise
    expected = 20 * np.log10(a / b) - 10 * np.log10(1 + noise_share)
    np.testing.assert_allclose(ds.distortion_db.sel(band="mode_100.0Hz").values, expected,
                               atol=0.05)
    assert float(ds.distortion_db.sel(band="mode_62.0Hz").max()) < -60.0
    assert float(ds.distortion_db.sel(band="elsewhere").max()) < -60.0


def test_crossing_flags_from_the_bin_speeds(sw):
    ds = metrics(sw, sw["n"])
    lo, hi = ds.rpm_lower.values / 60.0, ds.rpm_upper.values / 60.0
    for fam, orders in FAMILIES.items():
        for mode in MODES:
            want = [any(o * a <= mode + 4.0 and o * b >= mode - 4.0 for o in orders)
                    for a, b in zip(lo, hi, strict=True)]
            got = ds.crossing.sel(family=fam, band=f"mode_{mode:.1f}Hz").values
            np.testing.assert_array_equal(got.astype(bool), want)


def test_bands():
    names, limits = frequency_bands([62.0], 4.0, 10.0, 400.0)
    assert names == ["mode_62.0Hz", "elsewhere"]
    np.testing.assert_array_equal(limits, [[58.0, 66.0], [10.0, 400.0]])


def test_lengths_must_match(sw):
    with pytest.raises(ValueError, match="one length"):
        metrics(sw, sw["n"][:-1])
