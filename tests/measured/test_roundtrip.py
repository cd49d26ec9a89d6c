"""Round trips: a simulated-like record written with each format's own library and read
back through a ``measured:`` mapping gives the same values (within the format's
precision), SI units and the right time base."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest
from measured_bench import (
    EPOCH,
    FS,
    PPR,
    TORQUE_LINES,
    N,
    bench,
    line_amplitude,
    speed_true,
    write_csv,
    write_mat,
    write_mat73,
    write_mdf,
    write_tdms,
    write_tdms_array_column,
    write_testlab_mat,
    write_uff,
)

from gbpipe.measured import read

TACHO = {"quantity": "tacho", "pulses_per_rev": PPR}


@pytest.fixture(scope="module")
def b():
    return bench()


def _check_torque(ds, b, name="torque", rtol=1e-12):
    x = ds[name]
    assert x.attrs["units"] == "N m"
    np.testing.assert_allclose(ds["time"].values, np.arange(N) / FS, rtol=0, atol=1e-12)
    np.testing.assert_allclose(x.values, b.torque, rtol=rtol)
    for f, amp, _ in TORQUE_LINES:  # the known line amplitudes, within the noise
        assert line_amplitude(x.values, ds["time"].values, f) == pytest.approx(amp, abs=0.1)


def _check_pulses(ds, b, var="tacho"):
    pt = ds[var].values
    assert ds.attrs["pulses_per_rev"] == PPR and ds[var].attrs["pulses_per_rev"] == PPR
    true = b.pulses[b.pulses > 0.5 / FS]
    assert pt.size == true.size
    # sub-sample timing: far better than one sample (5e-4 s)
    np.testing.assert_allclose(pt, true, atol=0.05 / FS)
    np.testing.assert_array_equal(ds["pulse_time"].values, pt)


def test_tdms(tmp_path, b):
    path = tmp_path / "run7.tdms"
    write_tdms(path, b)
    spec = {"files": {"daq": {"path": "run7.tdms"}}, "sample_rate": FS,
            "signals": {"torque": {"file": "daq", "channel": "Measurements/Torque"},
                        "tacho": {"file": "daq", "channel": "Measurements/Tacho", **TACHO}}}
    ds = read(spec, tmp_path)
    _check_torque(ds, b)
    _check_pulses(ds, b)
    assert np.datetime64(ds.attrs["record_start"]) == EPOCH
    files = json.loads(ds.attrs["source_files"])
    assert files[0]["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    assert files[0]["bytes"] == path.stat().st_size


def test_tdms_array_column(tmp_path, b):
    write_tdms_array_column(tmp_path / "a.tdms", b)
    spec = {"files": {"daq": "a.tdms"}, "sample_rate": FS,
            "signals": {"torque": {"file": "daq", "channel": "Array/Torque"},
                        "tacho": {"file": "daq", "channel": "Array/Tacho", **TACHO}}}
    ds = read(spec, tmp_path)
    _check_torque(ds, b)
    _check_pulses(ds, b)


@pytest.mark.parametrize("sep,decimal", [(",", "."), (";", ","), ("\t", ".")])
def test_csv_angle_to_speed(tmp_path, b, sep, decimal):
    write_csv(tmp_path / "s.csv", {"time": b.t, "drive torque [N*m]": b.torque,
                                   "encoder 1": np.degrees(b.angle)}, sep=sep,
              decimal=decimal)
    spec = {"files": {"s": {"path": "s.csv", "time": "time", "decimal": decimal}},
            "sample_rate": FS,
            "signals": {"torque": {"file": "s", "channel": "drive torque"},
                        "speed": {"file": "s", "channel": "encoder 1", "unit": "deg",
                                  "quantity": "angle"}}}
    ds = read(spec, tmp_path)
    _check_torque(ds, b, rtol=1e-11)  # 12 significant digits in the text
    assert ds["speed"].attrs["units"] == "rad/s"
    # derivative of the encoder angle against the analytic speed (the ends carry the
    # Savitzky-Golay edge fit, 2 % of the record)
    inner = slice(40, -40)
    np.testing.assert_allclose(ds["speed"].values[inner], speed_true(b.t)[inner],
                               rtol=1e-6)


@pytest.mark.parametrize("binary", [0, 1])
def test_uff58(tmp_path, b, binary):
    write_uff(tmp_path / "r.uff", b, binary=binary)
    spec = {"files": {"u": "r.uff"}, "sample_rate": FS,
            "signals": {"torque": {"file": "u", "channel": "Torque"},
                        "speed": {"file": "u", "channel": "#2", "quantity": "angle"}}}
    ds = read(spec, tmp_path)
    # ASCII data sets store 13 significant digits (E20.12 as pyuff writes them)
    _check_torque(ds, b, rtol=1e-15 if binary else 1e-11)
    np.testing.assert_allclose(ds["speed"].values[40:-40], speed_true(b.t)[40:-40],
                               rtol=1e-6)


@pytest.mark.parametrize("writer, file", [
    (write_mat, {"path": "m.mat", "time": "t"}),               # v5: time base a variable
    (write_mat73, {"path": "m.mat", "sample_rate": FS}),       # v7.3 (HDF5): the file's rate
], ids=["v5", "v73"])
def test_mat_v5_and_v73(tmp_path, b, writer, file):
    writer(tmp_path / "m.mat", b)
    spec = {"files": {"m": file}, "sample_rate": FS,
            "signals": {"torque": {"file": "m", "channel": "torque", "unit": "N*m"},
                        "torque2": {"file": "m", "channel": "both[:, 1]", "unit": "N*m"},
                        "tacho": {"file": "m", "channel": "both[:,0]", **TACHO}}}
    ds = read(spec, tmp_path)
    _check_torque(ds, b)
    _check_torque(ds, b, "torque2")
    _check_pulses(ds, b)


def test_mat_testlab(tmp_path, b):
    write_testlab_mat(tmp_path / "tl.mat", b)
    spec = {"files": {"m": "tl.mat"}, "sample_rate": FS,
            "signals": {"torque": {"file": "m", "channel": "Signal"},
                        "torque2": {"file": "m", "channel": "Signal/Torque"}}}
    ds = read(spec, tmp_path)
    _check_torque(ds, b)
    _check_torque(ds, b, "torque2")


def test_mdf4(tmp_path, b):
    write_mdf(tmp_path / "r.mf4", b)
    spec = {"files": {"m": "r.mf4"}, "sample_rate": FS,
            "signals": {"torque": {"file": "m", "channel": "Torque"},
                        "speed": {"file": "m", "channel": "Encoder", "quantity": "angle"}}}
    ds = read(spec, tmp_path)
    _check_torque(ds, b)
    np.testing.assert_allclose(ds["speed"].values[40:-40], speed_true(b.t)[40:-40],
                               rtol=1e-6)
    assert "record_start" in ds.attrs
