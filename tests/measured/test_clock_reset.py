"""A logger's clock reset inside one file: with ``gaps: split`` a new segment, refused only
where several files would then disagree on the clock.

The files are written as loggers write them: a CSV whose time column starts again from 0
after the logger restarted, the same from two files of one logger, an interleaved TDMS
log with a time channel that jumps back, and beside a reset CSV a TDMS file whose
waveform time base (``wf_increment``) runs on. Both readers (in memory and streamed)
are run.
"""

from __future__ import annotations

import numpy as np
import pytest
from measured_bench import FS, bench, torque_true, write_csv
from nptdms import ChannelObject, TdmsWriter
from test_real_signals import logger_columns, mapping, write_interleaved

from gbpipe.errors import DataError
from gbpipe.measured import checks, read, stream
from gbpipe.measured.formats import delimited

N, RESET = 6000, 2500          # samples, the first sample after the reset
TORQUE = {"file": "a", "channel": "torque", "unit": "N*m"}


@pytest.fixture(autouse=True)
def small_blocks(monkeypatch):
    # the streamed reader's blocks smaller than the record: the reset inside a block
    monkeypatch.setattr(checks, "BLOCK", 1000)
    monkeypatch.setattr(stream, "OUT_BLOCK", 700)
    monkeypatch.setattr(delimited, "CHUNK", 900)


def _logged() -> tuple[np.ndarray, np.ndarray]:
    """Stamps that restart from 0 at sample RESET, and the torque of the true wall time."""
    b = bench(n=N, noise=0.0)
    stamps = np.concatenate([b.t[:RESET], b.t[:N - RESET]])
    return stamps, torque_true(b.t)


def _both(spec, folder):
    """The record read in memory and streamed into a file."""
    return read(spec, folder), read(spec, folder, out=folder / "rec.nc")


def test_a_reset_in_one_file_starts_a_segment(tmp_path):
    stamps, torque = _logged()
    write_csv(tmp_path / "log.csv", {"time": stamps, "torque": torque})
    spec = {"files": {"a": {"path": "log.csv", "time": "time"}}, "sample_rate": FS,
            "gaps": "split", "signals": {"torque": TORQUE}}
    for ds in _both(spec, tmp_path):
        seg = ds["segment"].values
        assert np.bincount(seg).tolist() == [RESET, N - RESET]
        # every sample is the logged one, in order (the grid is the logger's own)
        np.testing.assert_allclose(ds.torque.values, torque, rtol=1e-9)
        # the second era follows the first on the record's time axis
        t = ds.time.values
        assert t[seg == 1].min() > t[seg == 0].max()
    # gaps: refuse (the default) still refuses it, naming the sample and the way out
    with pytest.raises(DataError) as exc:
        read({**spec, "gaps": "refuse"}, tmp_path)
    assert exc.value.sample == RESET
    assert "gaps: split" in str(exc.value) and "log.csv" in str(exc.value)


def test_two_files_of_one_logger_reset_alike(tmp_path):
    stamps, torque = _logged()
    write_csv(tmp_path / "motors.csv", {"time": stamps, "torque": torque})
    write_csv(tmp_path / "sensors.csv", {"time": stamps, "speed": 2.0 * torque})
    spec = {"files": {"a": {"path": "motors.csv", "time": "time"},
                      "b": {"path": "sensors.csv", "time": "time"}},
            "sample_rate": FS, "gaps": "split",
            "signals": {"torque": TORQUE,
                        "speed": {"file": "b", "channel": "speed", "unit": "rad/s"}}}
    for ds in _both(spec, tmp_path):
        assert np.bincount(ds["segment"].values).tolist() == [RESET, N - RESET]
        np.testing.assert_allclose(ds.speed.values, 2.0 * torque, rtol=1e-9)


def test_a_reset_the_other_file_does_not_have_is_refused(tmp_path):
    stamps, torque = _logged()
    write_csv(tmp_path / "motors.csv", {"time": stamps, "torque": torque})
    # the DAQ's waveform runs on (wf_increment): no reset; both relative clocks
    with TdmsWriter(tmp_path / "daq.tdms") as w:
        w.write_segment([ChannelObject("Sensors", "speed", 2.0 * torque, properties={
            "wf_increment": 1.0 / FS, "wf_start_offset": 0.0, "unit_string": "rad/s"})])
    spec = {"files": {"a": {"path": "motors.csv", "time": "time"},
                      "b": {"path": "daq.tdms"}},
            "sample_rate": FS, "gaps": "split",
            "signals": {"torque": TORQUE,
                        "speed": {"file": "b", "channel": "Sensors/speed"}}}
    for out in (None, tmp_path / "rec.nc"):
        with pytest.raises(DataError) as exc:
            read(spec, tmp_path, out=out)
        text = str(exc.value)
        assert exc.value.sample == RESET
        assert "motors.csv" in text and "daq.tdms" in text and "without it" in text


def test_interleaved_logger_with_a_clock_jump_back(tmp_path):
    cols = logger_columns()
    cols["Time"] = cols["Time"].copy()
    cols["Time"][3000:] -= 1.0               # the logger's clock set back by 1 s
    write_interleaved(tmp_path / "run.tdms", cols)
    # the segments: one more than the forward gaps, counted here by a plain loop
    steps = np.diff(cols["Time"])
    nominal = np.median(steps)
    breaks = sum(1 for d in steps if d < 0 or d > 1.75 * nominal)
    ds = read(mapping(), tmp_path)
    assert ds["segment"].values.max() + 1 == breaks + 1
    # the torque after the jump is the logged one, sample for sample
    motor = ds.motor_torque.values[ds["segment"].values == ds["segment"].values.max()]
    np.testing.assert_allclose(motor, cols["MotorTorque"][-motor.size:], rtol=1e-9)
