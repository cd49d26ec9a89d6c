"""Tests of gbpipe.harmonics.metrics on the synthetic sweep with a 62 Hz resonance."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from harmonic_sweeps import FS, MESH

from gbpipe import harmonics

MODE_HZ = 62.0
FAMILIES = {"hss": [1, 2, 3], "mesh2": [MESH, 2 * MESH, 3 * MESH]}


@pytest.mark.parametrize("name, order, own", [
    ("hss", 1, "hss"), ("mesh2", MESH, "mesh2"), ("carrier2", MESH / 114, "mesh2"),
])
def test_variant_metrics(sw, name, order, own):
    r = harmonics.residual(sw["x"], FS, sw["pulses"], order)
    m = harmonics.removal_metrics(sw["x"], r, FS, sw["pulses"], FAMILIES, [MODE_HZ])
    other = "mesh2" if own == "hss" else "hss"
    assert float(m.attenuation.sel(family=own)) >= 40.0
    assert abs(float(m.attenuation.sel(family=other))) < 1.0
    # The resonance band outside family crossings: only the (1 - 1/N) loss, < 1 dB.
    assert abs(float(m.mode_change.sel(mode=0))) < 1.0
    ok = m.crossing.sum("family").isel(mode=0).values == 0
    assert np.all(np.abs(m.mode_change_vs_rpm.isel(mode=0).values[ok]) < 1.5)


def test_crossing_flags_where_family_passes_the_mode(sw):
    m = harmonics.removal_metrics(sw["x"], sw["x"], FS, sw["pulses"], FAMILIES, [MODE_HZ])
    cross = m.crossing.isel(mode=0)
    # HSS orders 1-3 stay below 56 Hz at 1120 rpm: never within 62 +- 4 Hz.
    assert int(cross.sel(family="hss").sum()) == 0
    # Mesh order 5.3569 hits 62 Hz at 694 rpm: flagged bins are those around it.
    flagged = cross.sel(family="mesh2").values.astype(bool)
    lo = m.rpm_lower.values[flagged]
    hi = m.rpm_upper.values[flagged]
    assert flagged.any() and lo.min() <= 60 * MODE_HZ / MESH <= hi.max()
    assert hi.max() - lo.min() < 250  # only a few bins
    # Identical signals: no change anywhere; nothing removed.
    np.testing.assert_allclose(m.mode_change_all.values, 0.0, atol=1e-9)
    np.testing.assert_allclose(m.attenuation.values, 0.0, atol=1e-9)


def test_metric_sees_an_eaten_resonance(sw):
    # Remove the resonance itself: the band change must show it (not only 1/N).
    after = sw["x"] - sw["res"]
    m = harmonics.mode_band_change(sw["x"], after, FS, [MODE_HZ], pulse_times=sw["pulses"],
                                 families=FAMILIES)
    assert float(m.mode_change.isel(mode=0)) < -10.0
    half = harmonics.mode_band_change(sw["x"], 0.5 * sw["x"], FS, [MODE_HZ], rpm=sw["rpm"])
    assert float(half.mode_change.isel(mode=0)) == pytest.approx(-6.0206, abs=1e-6)


def test_unbiased_preserves_resonance_band(sw):
    r = harmonics.residual(sw["x"], FS, sw["pulses"], MESH, unbiased=True)
    m = harmonics.mode_band_change(sw["x"], r, FS, [MODE_HZ], pulse_times=sw["pulses"],
                                 families=FAMILIES)
    assert abs(float(m.mode_change.isel(mode=0))) < 0.5


def test_band_measure_separates_cascade_from_joint(clean):
    x = clean["hss"] + clean["mesh"]
    fam = {"hss": harmonics.family_orders(1, 20), "mesh2": harmonics.family_orders(MESH, 20)}
    out = {}
    for mode in ("cascade", "joint"):
        r = harmonics.residual_joint(x, FS, clean["pulses"], [1, MESH], mode=mode)
        m = harmonics.family_attenuation(x, r, FS, clean["pulses"], fam, band=0.1)
        out[mode] = m.attenuation_band.values
        # Lines at the exact orders go in both cases: the line measure cannot tell.
        assert np.all(m.attenuation.values > 40.0)
    assert np.all(out["joint"] >= 35.0), out
    assert np.any(out["cascade"] < 30.0), out


def test_family_orders_exact_from_fraction():
    c = Fraction(609, 12960)
    o = harmonics.family_orders(c, 5.36)
    assert o.size == 114 and o[-1] == pytest.approx(114 * 609 / 12960, rel=1e-15)
    np.testing.assert_allclose(harmonics.family_orders(1.0, 3.5), [1.0, 2.0, 3.0])


def test_removal_rejects_bad_input(sw):
    x = sw["x"]
    with pytest.raises(ValueError, match="same length"):
        harmonics.family_attenuation(x, x[:-1], FS, sw["pulses"], FAMILIES)
    with pytest.raises(TypeError, match="families must be a non-empty mapping"):
        harmonics.family_attenuation(x, x, FS, sw["pulses"], {})
    with pytest.raises(ValueError, match=r"families\['bad'\] must be > 0"):
        harmonics.family_attenuation(x, x, FS, sw["pulses"], {"bad": [1, -2]})
    with pytest.raises(ValueError, match="half_width must be > 0"):
        harmonics.mode_band_change(x, x, FS, [MODE_HZ], rpm=sw["rpm"], half_width=0.0)


def test_several_signals_after_score_as_separate_calls(clean):
    # The list form tracks `before` once: each signal after removal must get exactly the
    # numbers of a call of its own (the band measure too)
    x = clean["hss"] + clean["mesh"]
    fam = {"hss": harmonics.family_orders(1, 3), "mesh2": harmonics.family_orders(MESH, 12)}
    rng = np.random.default_rng(3)
    afters = [harmonics.residual(x, FS, clean["pulses"], 1),
              0.01 * rng.standard_normal(x.size) + 0.1 * clean["mesh"]]
    together = harmonics.family_attenuation(x, afters, FS, clean["pulses"], fam, band=0.1,
                                            rpm_bins=4)
    assert isinstance(together, list) and len(together) == 2
    for a, got in zip(afters, together, strict=True):
        alone = harmonics.family_attenuation(x, a, FS, clean["pulses"], fam, band=0.1,
                                             rpm_bins=4)
        for v in alone.data_vars:
            np.testing.assert_array_equal(got[v].values, alone[v].values)
        np.testing.assert_array_equal(got.rpm.values, alone.rpm.values)
    with pytest.raises(ValueError, match="empty list"):
        harmonics.family_attenuation(x, [], FS, clean["pulses"], fam)
