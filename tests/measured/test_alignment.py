"""Several files on one clock: the overlap window, resampling onto the record grid
(polyphase, fractional delay, band-limited), and the gap policies."""

from __future__ import annotations

import numpy as np
import pytest
from measured_bench import FS, bench, torque_true, write_csv, write_mat, write_tdms

from gbpipe.errors import DataError
from gbpipe.measured import read
from gbpipe.measured.timebase import Piece, resample

EDGE = 40  # samples at each end within a filter length of the data's edge


def test_issue_example_three_files(tmp_path):
    """CSV with a time channel starting late, TDMS with wf_start_offset, MAT at 4 kHz."""
    b = bench(noise=0.0)
    t_csv = b.t + 0.25
    write_csv(tmp_path / "motors.csv", {"time": t_csv, "drive torque": torque_true(t_csv)})
    write_tdms(tmp_path / "run7.tdms", b, start_offset=0.1, epoch=None)
    b4 = bench(n=8000, fs=2 * FS, noise=0.0)
    write_mat(tmp_path / "acq.mat", b4)
    spec = {"files": {"motors": {"path": "motors.csv", "time": "time"},
                      "daq": {"path": "run7.tdms"},
                      "scope": {"path": "acq.mat", "sample_rate": 2 * FS}},
            "sample_rate": 1000.0,
            "signals": {
                "motor_torque_driver": {"file": "motors", "channel": "drive torque",
                                        "unit": "N*m"},
                "torque_meter": {"file": "daq", "channel": "Measurements/Torque",
                                 "unit": "kN*m", "scale": 1.0, "offset": 0.0},
                "scope_torque": {"file": "scope", "channel": "torque", "unit": "kN*m",
                                 "scale": 1e-3},
                "tacho": {"file": "daq", "channel": "Measurements/Tacho",
                          "quantity": "tacho", "pulses_per_rev": 8}},
            "gaps": "refuse"}
    ds = read(spec, tmp_path, name="run12")
    # latest start (CSV), earliest end (the 4 kHz MAT file)
    start, end = 0.25, min(0.1 + (b.t.size - 1) / FS, (8000 - 1) / (2 * FS))
    assert ds.attrs["record_start_s"] == pytest.approx(start, abs=1e-12)
    n = int(np.floor((end - start) * 1000.0 + 1e-9)) + 1
    assert ds.sizes["time"] == n
    t_abs = start + ds["time"].values
    inner = slice(EDGE, -EDGE)
    for var, t_src0 in (("motor_torque_driver", 0.0), ("torque_meter", 0.1),
                        ("scope_torque", 0.0)):
        np.testing.assert_allclose(ds[var].values[inner],
                                   torque_true(t_abs - t_src0)[inner], atol=0.05)
    pulses = ds["tacho"].values
    assert pulses.min() >= 0 and pulses.max() <= ds["time"].values[-1]
    np.testing.assert_allclose(pulses + start - 0.1,
                               b.pulses[(b.pulses + 0.1 >= start) & (b.pulses + 0.1 <= end)],
                               atol=0.05 / FS)


@pytest.mark.parametrize("fs_out", [1000.0, 1500.0, 1234.5678])
def test_resample_paths(fs_out):
    """Polyphase (1000, 1500) and band-limited (irrational ratio) against the analytic
    signal, with a grid offset by a fraction of a source sample."""
    fs_in = 2000.0
    f_sig = 60.0
    t = np.arange(8000) / fs_in
    piece = Piece(np.sin(2 * np.pi * f_sig * t), 0.0, 1 / fs_in)
    start = 0.123456
    n = int((t[-1] - start) * fs_out) - 1
    y = resample(piece, start, fs_out, n)
    tt = start + np.arange(n) / fs_out
    np.testing.assert_allclose(y[EDGE:-EDGE], np.sin(2 * np.pi * f_sig * tt)[EDGE:-EDGE],
                               atol=2e-3)


@pytest.mark.parametrize("fs_out", [1000.0, 1234.5678])
def test_resample_is_anti_aliased(fs_out):
    """A 900 Hz tone, above the output Nyquist frequency, does not fold into the record
    (nearest-sample or linear interpolation would keep most of it)."""
    fs_in = 2000.0
    t = np.arange(8000) / fs_in
    piece = Piece(np.sin(2 * np.pi * 900.0 * t), 0.0, 1 / fs_in)
    y = resample(piece, 0.01, fs_out, int(3.9 * fs_out))
    assert np.sqrt(np.mean(y[EDGE:-EDGE] ** 2)) < 0.01 * np.sqrt(0.5)


def _gappy_csv(tmp_path, drop):
    b = bench(noise=0.0)
    keep = np.setdiff1d(np.arange(b.t.size), drop)
    write_csv(tmp_path / "g.csv", {"time": b.t[keep], "torque": b.torque[keep]})
    return b, {"files": {"g": {"path": "g.csv", "time": "time"}}, "sample_rate": FS,
               "signals": {"torque": {"file": "g", "channel": "torque", "unit": "N*m"}}}


def test_gaps_split(tmp_path):
    b, spec = _gappy_csv(tmp_path, np.arange(1000, 1050))
    ds = read({**spec, "gaps": "split"}, tmp_path)
    seg = ds["segment"].values
    assert np.bincount(seg).tolist() == [1000, b.t.size - 1050]
    np.testing.assert_allclose(ds["time"].values[seg == 1][0], 1050 / FS)
    np.testing.assert_allclose(ds["torque"].values, torque_true(ds["time"].values),
                               rtol=1e-11)


def test_gaps_interpolate(tmp_path):
    b, spec = _gappy_csv(tmp_path, np.arange(1000, 1003))
    ds = read({**spec, "gaps": {"interpolate_upto": 3}}, tmp_path)
    assert ds.sizes["time"] == b.t.size and "segment" not in ds.coords
    x = ds["torque"].values
    np.testing.assert_allclose(np.delete(x, range(1000, 1003)),
                               np.delete(b.torque, range(1000, 1003)), rtol=1e-11)
    # the bridge is the straight line between the samples around the gap
    np.testing.assert_allclose(x[1000:1003], np.interp(np.arange(1000, 1003), [999, 1003],
                                                       b.torque[[999, 1003]]), rtol=1e-11)
    with pytest.raises(DataError, match=r"g\.csv.*3 missing samples.*interpolate_upto = 2"):
        read({**spec, "gaps": {"interpolate_upto": 2}}, tmp_path)


def test_timestamp_jitter_is_not_noise(tmp_path):
    """Stamps jittered by ±0.3 sample (a logger's clock) on a uniform ADC clock."""
    b = bench(noise=0.0)
    rng = np.random.default_rng(3)
    t_st = b.t + rng.uniform(-0.3, 0.3, b.t.size) / FS
    write_csv(tmp_path / "j.csv", {"time": t_st, "torque": b.torque})
    spec = {"files": {"j": {"path": "j.csv", "time": "time"}}, "sample_rate": FS,
            "signals": {"torque": {"file": "j", "channel": "torque", "unit": "N*m"}}}
    ds = read(spec, tmp_path)
    # the clock fit lands within a few 1e-3 samples of the true grid: values stay exact
    # up to that fractional delay
    np.testing.assert_allclose(ds["torque"].values[EDGE:-EDGE], b.torque[EDGE:-EDGE],
                               atol=0.5)


def test_same_channel_twice_in_two_units(tmp_path):
    """Each signal converts its own copy: one column mapped as N*m and as kN*m."""
    b = bench(noise=0.0)
    write_csv(tmp_path / "s.csv", {"time": b.t, "torque": b.torque})
    write_mat(tmp_path / "m.mat", b)
    spec = {"files": {"s": {"path": "s.csv", "time": "time"},
                      "m": {"path": "m.mat", "time": "t"}}, "sample_rate": FS,
            "signals": {"a": {"file": "s", "channel": "torque", "unit": "N*m"},
                        "b": {"file": "s", "channel": "torque", "unit": "kN*m"},
                        "c": {"file": "m", "channel": "torque", "unit": "N*m", "scale": 2.0},
                        "d": {"file": "m", "channel": "torque", "unit": "kN*m"}}}
    ds = read(spec, tmp_path)
    np.testing.assert_allclose(ds["a"].values, b.torque, rtol=1e-11)
    np.testing.assert_allclose(ds["b"].values, 1e3 * b.torque, rtol=1e-11)
    np.testing.assert_allclose(ds["c"].values, 2 * b.torque, rtol=1e-15)
    np.testing.assert_allclose(ds["d"].values, 1e3 * b.torque, rtol=1e-15)
