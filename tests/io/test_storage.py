"""On-disk form of gbpipe.io.write: float32 only where a series' noise leaves room, rounded
to the power-of-two step its noise floor allows (against closed forms of the rounding),
compression applied, plain seconds on time."""

from __future__ import annotations

import re

import h5py
import netCDF4
import numpy as np
import pytest
import xarray as xr
from scipy import signal

from gbpipe import io

FS = 5000.0  # Hz
N = 1 << 16  # samples


def _record(series: dict[str, np.ndarray]) -> xr.Dataset:
    t = np.arange(N) / FS
    return xr.Dataset(
        {name: ("time", x, {"units": "rad/s", "long_name": name}) for name, x in series.items()},
        coords={"time": ("time", t, {"units": "s", "long_name": "time from record start"})})


def _step(stored: np.ndarray) -> float:
    """The largest power of two of which every stored value is a multiple."""
    v = stored.astype(np.float64)
    k = 40
    while not np.all(np.mod(v, 2.0**k) == 0):
        k -= 1
    return 2.0**k


def _ulp32(x: float) -> float:
    """float32's spacing at |x| (closed form: 2^(floor(log2|x|) - 23))."""
    return 2.0 ** (np.floor(np.log2(abs(x))) - 23)


# (offset, sensor noise rms): speeds and torques of several machines, signs and scales
CASES = [(117.0, 2e-3), (16250.0, 10.0), (-3.5, 1e-4), (0.02, 1e-6), (1.0e5, 0.5)]


@pytest.mark.parametrize("offset, sigma", CASES)
def test_noisy_series_is_float32_within_the_declared_rounding_below_its_noise(
        tmp_path, offset, sigma):
    rng = np.random.default_rng(7)
    t = np.arange(N) / FS
    x = offset * (1.0 + 0.01 * np.sin(2 * np.pi * 3.0 * t)) + sigma * rng.standard_normal(N)
    path = io.write(_record({"x": x}), tmp_path / "a.nc", stage="unit", noisy=["x"])
    with netCDF4.Dataset(path) as nc:
        assert nc["x"].dtype == np.float32
        stored = nc["x"][:].data
    q = _step(stored)
    back = io.read(path)
    err = back.x.values.astype(np.float64) - x
    # round to nearest multiple of q (then float32's own rounding, where finer)
    top = np.max(np.abs(x))
    assert np.max(np.abs(err)) <= 0.5 * q + 0.5 * _ulp32(top)
    # the declared bound holds, and is no wider than the error there is (65536 draws of
    # a uniform rounding error reach within 1e-3 of its end)
    declared = float(re.search(r"rounding error at most ([0-9.e+-]+)",
                               back.x.attrs["comment"]).group(1))
    assert 0.9 * declared <= np.max(np.abs(err)) <= declared * (1 + 5e-3)
    # the error is white: its spectrum lies MARGIN_DB under the noise's at every frequency
    # (Welch estimates of 127 segments: the smallest of 513 ratios scatters by ~1.5 dB)
    f, pxx = signal.welch(x, FS, nperseg=1024)
    _, pee = signal.welch(err, FS, nperseg=1024)
    margin = 10 * np.log10(np.min(pxx[1:] / pee[1:]))
    assert margin >= io.MARGIN_DB - 2.0, (margin, q)
    # q is the largest power of two whose rounding (rms q / sqrt 12) lies MARGIN_DB under
    # the noise: twice q would not (4 dB: the writer's estimate of the floor is the
    # smallest of 512 bands of 64 lines)
    assert q / np.sqrt(12) <= sigma * 10 ** (-(io.MARGIN_DB - 2.0) / 20), q
    assert 2 * q / np.sqrt(12) > sigma * 10 ** (-(io.MARGIN_DB + 4.0) / 20), q
    # and its rms lies MARGIN_DB under the sensor noise the test drew
    assert np.std(err) < sigma * 10 ** (-(io.MARGIN_DB - 2.0) / 20)


def test_rounded_to_nearest_multiple_of_a_power_of_two(tmp_path):
    sigma = 2e-3
    x = 117.0 + sigma * np.random.default_rng(8).standard_normal(N)
    path = io.write(_record({"x": x}), tmp_path / "a.nc", stage="unit", noisy=["x"])
    with netCDF4.Dataset(path) as nc:
        stored = nc["x"][:].data
    q = _step(stored)
    # closed form for white noise: the largest 2^k with 2^k / sqrt(12) <= sigma / 100,
    # or half that where the estimated floor scatters low
    expected = 2.0 ** np.floor(np.log2(sigma * np.sqrt(12) * 10 ** (-io.MARGIN_DB / 20)))
    assert q in (expected / 2, expected), (q, expected)
    # every value is the nearest multiple of q (no value lies on a tie here)
    np.testing.assert_array_equal(stored.astype(np.float64), np.round(x / q) * q)


def test_no_stretch_rounds_coarser_than_the_margin_allows(tmp_path):
    # a residual: white noise of rms sigma about 0, and 0.2 % of raw samples at 16 kN·m
    # on its edges (where the removal did not reach). Averaged over the series, a
    # relative rounding 2^6 times coarser there would still pass the spectral margin; the
    # writer's step is absolute: its rounding (uniform, rms q / sqrt 12) lies MARGIN_DB
    # under the noise at the edges as in the bulk.
    sigma = 300.0
    x = sigma * np.random.default_rng(9).standard_normal(N)
    x[:64] += 16250.0
    x[-64:] += 16250.0
    path = io.write(_record({"x": x}), tmp_path / "a.nc", stage="unit", noisy=["x"])
    with netCDF4.Dataset(path) as nc:
        stored = nc["x"][:].data
    q = _step(stored)
    assert q / np.sqrt(12) <= sigma * 10 ** (-(io.MARGIN_DB - 2.0) / 20), q
    # and no finer than that needs (the smallest of 512 band estimates of 64 lines each
    # lies up to ~3 dB under the noise floor)
    assert 2 * q / np.sqrt(12) > sigma * 10 ** (-(io.MARGIN_DB + 4.0) / 20), q
    # the edges rounded as finely as the bulk: the same absolute step
    edges = np.r_[:64, N - 64:N]
    assert np.max(np.abs(stored[edges].astype(np.float64) - x[edges])) <= 0.5 * q


@pytest.mark.parametrize("offset, sigma", CASES)
def test_margin_is_noise_over_rounding_rms(offset, sigma):
    # white noise over white rounding: the PSD ratio is sigma^2 over the rounding
    # variance, whose closed form for round-to-nearest is ulp^2/12 (uniform error).
    # Each of the 512 bands averages 256 lines here (2^18 samples): the ratio of two such
    # estimates scatters by ~10 % rms, so its minimum over the bands lies 1-2 dB under
    rng = np.random.default_rng(3)
    x = offset + sigma * rng.standard_normal(1 << 18)
    expected = 20 * np.log10(sigma / (_ulp32(offset) / np.sqrt(12)))
    got = io.rounding_margin_db(x)
    assert expected - 3.0 <= got <= expected + 0.5, (got, expected)


def test_series_without_noise_room_stays_float64_and_exact(tmp_path):
    t = np.arange(N) / FS
    rng = np.random.default_rng(5)
    ulp = _ulp32(117.0)
    series = {
        # a smooth response: float32 would bury its high-frequency content
        "smooth": 117.0 + np.sin(2 * np.pi * 3.0 * t),
        # noise only 20 dB over float32's rounding: below the 40 dB margin
        "quiet": 117.0 + 10 * ulp / np.sqrt(12) * rng.standard_normal(N),
        # noisy but named by nobody: the producer did not ask
        "other": 117.0 + 1e-2 * rng.standard_normal(N),
    }
    path = io.write(_record(series), tmp_path / "a.nc", stage="unit",
                    noisy=["smooth", "quiet"])
    back = io.read(path)
    for name, x in series.items():
        assert back[name].dtype == np.float64, name
        np.testing.assert_array_equal(back[name].values, x, err_msg=name)
        assert "comment" not in back[name].attrs, name


def test_noisy_names_only_time_series(tmp_path):
    ds = _record({"x": np.ones(N)})
    ds["gain"] = ("row", [1.0, 2.0], {"units": "1", "long_name": "gain"})
    for wrong in ("gain", "missing"):
        with pytest.raises(ValueError, match=wrong):
            io.write(ds, tmp_path / "a.nc", stage="unit", noisy=[wrong])


def test_compression_is_applied_and_pays(tmp_path):
    rng = np.random.default_rng(11)
    sigma = 2e-3
    x = 117.0 + sigma * rng.standard_normal(N)
    path = io.write(_record({"x": x}), tmp_path / "a.nc", stage="unit", noisy=["x"])
    with netCDF4.Dataset(path) as nc:
        for name in ("time", "x"):
            filters = nc[name].filters()
            assert filters["zlib"] and filters["shuffle"] and filters["complevel"] == 1, name
        q = _step(nc["x"][:].data)
    with h5py.File(path) as h5:
        stored = {name: h5[name].id.get_storage_size() for name in ("time", "x")}
    # Entropy bound: values of Gaussian noise of rms sigma on a grid of step q carry
    # log2(sigma sqrt(2 pi e) / q) bits each (10.1 of 32 at float32's spacing at 117, 3
    # bits fewer on the writer's step here), so x cannot shrink below that; zlib on
    # shuffled bytes gets within 1.6x of it (its Huffman stage codes each byte plane
    # apart).
    bits = np.log2(sigma * np.sqrt(2 * np.pi * np.e) / q)
    bound = N * bits / 8
    assert bound < stored["x"] < 1.6 * bound, (stored["x"], bound)
    # a regular time axis is near all redundancy: shuffled, its bytes repeat
    assert stored["time"] < N * 8 / 10, stored["time"]


def test_plain_xarray_gives_time_in_seconds_from_zero(tmp_path):
    x = np.random.default_rng(2).standard_normal(N)
    path = io.write(_record({"x": x}), tmp_path / "a.nc", stage="unit")
    with xr.open_dataset(path) as plain:  # no gbpipe, CF decoding on
        assert plain.time.dtype == np.float64 and plain.time.attrs["units"] == "s"
        assert plain.time.values[0] == 0.0
        np.testing.assert_allclose(np.diff(plain.time.values), 1 / FS, rtol=1e-9)
        # computing with it: the record lasts N / FS seconds
        assert float(plain.time[-1] - plain.time[0]) == pytest.approx((N - 1) / FS)


def test_forced_float32_says_what_it_cost(tmp_path):
    x = 1000.0 + np.random.default_rng(4).standard_normal(N)
    path = io.write(_record({"x": x}), tmp_path / "a.nc", stage="unit", float32=True)
    back = io.read(path)
    assert back.x.dtype == np.float32 and back.time.dtype == np.float64
    assert np.max(np.abs(back.x.values - x)) <= 0.5 * _ulp32(np.max(np.abs(x)))
    assert "producing stage's choice" in back.x.attrs["comment"]
