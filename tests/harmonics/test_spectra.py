"""Tests of gbpipe.harmonics.spectra: waterfalls vs rpm against analytic lines and Parseval."""

from __future__ import annotations

import numpy as np
import pytest
from harmonic_sweeps import FS, MESH, make_sweep

from gbpipe import harmonics as spectra
from gbpipe import io
from gbpipe.units import squared_units


@pytest.fixture(scope="module")
def sw():
    return make_sweep(noise=0.0)


def all_have_metadata(ds) -> bool:
    variables = {**ds.coords, **ds.data_vars}.values()
    return all({"units", "long_name"} <= set(v.attrs) for v in variables)


def test_fixed_tone_line_height_and_units(sw):
    # 100 Hz tone, on a bin at 0.5 Hz resolution: spectrum scaling shows A^2/2 at all rpm.
    x = 2.0 * np.cos(2 * np.pi * 100.0 * sw["t"])
    ds = spectra.power_spectrum_vs_rpm(x, FS, rpm=sw["rpm"], resolution=0.5, rpm_bins=6,
                                       units="N m", long_name="torque")
    peak = ds.power.sel(frequency=100.0)
    np.testing.assert_allclose(peak.values, 2.0, rtol=1e-3)
    assert ds.power.attrs["units"] == "N2 m2"
    assert ds.rpm.attrs["units"] == "rev/min" and ds.frequency.attrs["units"] == "Hz"
    assert all_have_metadata(ds)
    assert ds.sizes["rpm"] == 6 and int(ds.n_averages.sum()) > 6


def test_density_integrates_to_variance(sw):
    x = np.random.default_rng(0).standard_normal(sw["t"].size)
    ds = spectra.power_spectrum_vs_rpm(x, FS, rpm=sw["rpm"], resolution=2.0, rpm_bins=4,
                                       scaling="density", units="N m")
    area = ds.power.sum("frequency").values * float(ds.frequency[1])
    np.testing.assert_allclose(area, 1.0, rtol=0.03)  # Parseval, unit variance
    assert ds.power.attrs["units"] == "N2 m2 Hz-1"


def test_order_line_follows_rpm(sw):
    # Order 3 appears at 3 * rpm / 60 Hz in every bin of the waterfall.
    x = np.cos(3 * sw["theta"])
    ds = spectra.power_spectrum_vs_rpm(x, FS, pulse_times=sw["pulses"], resolution=1.0,
                                       rpm_bins=8)
    f_peak = ds.frequency.values[ds.power.argmax("frequency").values]
    lo, hi = 3 * ds.rpm_lower.values / 60, 3 * ds.rpm_upper.values / 60
    assert np.all((f_peak >= lo - 1.0) & (f_peak <= hi + 1.0))


def test_rpm_from_pulses_matches_rpm_array(sw):
    x = np.cos(3 * sw["theta"])
    edges = np.linspace(400, 1120, 7)
    a = spectra.power_spectrum_vs_rpm(x, FS, rpm=sw["rpm"], rpm_bins=edges)
    b = spectra.power_spectrum_vs_rpm(x, FS, pulse_times=sw["pulses"], rpm_bins=edges)
    # Frames outside the pulse span (first/last rev) have no speed from pulses.
    assert np.abs(a.n_averages.values - b.n_averages.values).max() <= 2
    ok = (a.n_averages.values > 2) & (b.n_averages.values > 2)
    np.testing.assert_allclose(a.power.values[ok].sum(1), b.power.values[ok].sum(1), rtol=0.05)


@pytest.mark.parametrize(("nper", "overlap", "scaling"), [(800, 0.5, "spectrum"),
                                                         (999, 0.3, "density")])
def test_frames_are_whole_and_start_at_multiples_of_the_hop(nper, overlap, scaling):
    """At constant speed every frame falls in one bin: the bin must hold the mean of the
    periodograms of frames x[k hop : k hop + nper], computed here by hand."""
    rng = np.random.default_rng(3)
    x = rng.standard_normal(20_000) + np.cos(2 * np.pi * 0.1 * np.arange(20_000))
    ds = spectra.power_spectrum_vs_rpm(x, FS, rpm=np.full(x.size, 600.0),
                                       resolution=FS / nper, overlap=overlap, rpm_bins=1,
                                       window="hann", scaling=scaling)
    hop = int(round(nper * (1 - overlap)))
    starts = np.arange(0, x.size - nper + 1, hop)
    w = 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(nper) / nper)  # periodic Hann
    frames = np.stack([x[k:k + nper] * w for k in starts])
    pg = np.abs(np.fft.rfft(frames, axis=1)) ** 2
    pg /= w.sum() ** 2 if scaling == "spectrum" else FS * np.sum(w**2)
    pg[:, 1:] *= 2.0  # one-sided: all but DC (and Nyquist for even nper)
    if nper % 2 == 0:
        pg[:, -1] /= 2.0
    assert int(ds.n_averages[0]) == starts.size
    np.testing.assert_allclose(ds.power.values[0], pg.mean(axis=0), rtol=1e-9, atol=0)


def test_order_spectrum_vs_rpm_lines(sw):
    x = 2.0 * np.cos(3 * sw["theta"]) + 0.7 * np.cos(MESH * sw["theta"])
    ds = spectra.order_spectrum_vs_rpm(x, FS, sw["pulses"], resolution=0.1, max_order=12,
                                       rpm_bins=5, units="N m", long_name="torque")
    np.testing.assert_allclose(ds.power.sel(order=3.0, method="nearest").values, 2.0, rtol=1e-2)
    # The mesh line sits between bins (5.3569): peak near 5.36 in every rpm bin.
    mesh = ds.power.sel(order=slice(4.5, 6.5))
    peak_order = mesh.order.values[mesh.argmax("order").values]
    assert np.all(np.abs(peak_order - MESH) <= 0.1)
    assert ds.power.attrs["units"] == "N2 m2" and ds.order.attrs["units"] == "1"
    assert all_have_metadata(ds)


def test_waterfall_writes_through_gbpipe_io(sw, tmp_path):
    ds = spectra.order_spectrum_vs_rpm(np.cos(3 * sw["theta"]), FS, sw["pulses"], rpm_bins=3,
                                       max_order=5)
    path = io.write(ds, tmp_path / "w.nc", stage="tsa", config={}, wildcards={"variant": "x"})
    back = io.read(path)
    np.testing.assert_allclose(back.power.values, ds.power.values)


def test_squared_units():
    assert squared_units("N m") == "N2 m2"
    assert squared_units("rad s-1") == "rad2 s-2"
    assert squared_units("1") == "1"
    assert squared_units("kN.m") == "(kN.m)^2"


def test_spectra_reject_bad_input(sw):
    x = sw["x"]
    with pytest.raises(ValueError, match="exactly one of rpm"):
        spectra.power_spectrum_vs_rpm(x, FS)
    with pytest.raises(ValueError, match="exactly one of rpm"):
        spectra.power_spectrum_vs_rpm(x, FS, rpm=sw["rpm"], pulse_times=sw["pulses"])
    with pytest.raises(ValueError, match="resolution=0.001 Hz needs frames"):
        spectra.power_spectrum_vs_rpm(x, FS, rpm=sw["rpm"], resolution=0.001)
    with pytest.raises(ValueError, match="rpm must have one value per sample"):
        spectra.power_spectrum_vs_rpm(x, FS, rpm=sw["rpm"][:-1])
    with pytest.raises(ValueError, match="scaling must be"):
        spectra.power_spectrum_vs_rpm(x, FS, rpm=sw["rpm"], scaling="psd")
    with pytest.raises(ValueError, match="rpm_bins must be"):
        spectra.power_spectrum_vs_rpm(x, FS, rpm=sw["rpm"], rpm_bins=[500, 400])
    with pytest.raises(ValueError, match="choose a coarser resolution"):
        spectra.order_spectrum_vs_rpm(x, FS, sw["pulses"], resolution=1e-4)
