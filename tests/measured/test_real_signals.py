"""Real bench signals read as they are, with a mapping only.

A 1 kHz logger file of another bench: nine columns interleaved row by row in the only
channel of a TDMS file (no per-channel metadata), a torque set-point at 0 between bursts,
a drive speed the drive updates every 50 samples, an encoder counter (1024 counts/rev), a
dropped row and a forward clock jump. Every value read is compared with what was written
(independently: the written arrays, plain numpy), the pulse times with the encoder's
true revolutions; the real refusals (a declared range exceeded, NaN, a backward clock
where gaps are refused, a non-whole count) keep naming file, channel, sample and fix.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
import xarray as xr
from measured_bench import PPR, angle_true, bench, write_csv
from nptdms import ChannelObject, TdmsWriter

from gbpipe.config import load
from gbpipe.errors import ConfigError, DataError
from gbpipe.harmonics import record_residuals, sweep_waterfalls
from gbpipe.measured import format_listing, list_channels, read
from tests.conftest import CI_CONFIG, CONFIG

FS = 1000.0
ROWS = 6000
COUNTS = 1024                       # encoder counts per revolution
COLUMNS = ["Time", "MotorTorqueSet", "MotorTorque", "MotorSpeed", "LoadTorque",
           "LoadSpeed", "EncoderCount", "Temperature", "Status"]
DROPPED = 2000                      # row missing from the file
JUMP_AT, JUMP = 4000, 0.25          # rows from JUMP_AT on are stamped JUMP s later
HOLD = 50                           # samples between drive speed updates


def speed_rpm(t):
    return 1500.0 + 100.0 * np.sin(2 * np.pi * 0.5 * t)


def revolutions(t):
    """Shaft angle [rev] of speed_rpm, in closed form."""
    return 25.0 * t - 100.0 / 60.0 / (2 * np.pi * 0.5) * (np.cos(2 * np.pi * 0.5 * t) - 1.0)


def logger_columns(seed: int = 7, jump: float = JUMP) -> dict[str, np.ndarray]:
    """The columns as the logger wrote them (a dropped row, a clock jump of ``jump`` s)."""
    rng = np.random.default_rng(seed)
    k = np.arange(ROWS)
    t = k / FS + np.where(k >= JUMP_AT, jump, 0.0)
    burst = ((k % 2000) >= 500) & ((k % 2000) < 1300)       # bursts of 0.8 s, 0 between
    setpoint = np.where(burst, 1500.0, 0.0)
    speed = speed_rpm(t[(k // HOLD) * HOLD])                # held between drive updates
    cols = {"Time": t, "MotorTorqueSet": setpoint,
            "MotorTorque": setpoint + 5.0 * rng.standard_normal(ROWS),
            "MotorSpeed": speed, "LoadTorque": -setpoint + 5.0 * rng.standard_normal(ROWS),
            "LoadSpeed": speed + 0.1 * rng.standard_normal(ROWS),
            "EncoderCount": np.floor(revolutions(t) * COUNTS),
            "Temperature": 40.0 + 0.01 * k / FS, "Status": (k % 7 == 0).astype(float)}
    return {name: np.delete(v, DROPPED) for name, v in cols.items()}


def write_interleaved(path, cols: dict[str, np.ndarray]) -> None:
    """All columns row by row in one channel named like the first, with no properties."""
    with TdmsWriter(path) as w:
        w.write_segment([ChannelObject("Measurements", "Time",
                                       np.column_stack([cols[c] for c in COLUMNS]).ravel())])


def mapping(**tacho) -> dict:
    return {"files": {"log": {"path": "run.tdms", "interleaved": COLUMNS, "time": "Time"}},
            "sample_rate": FS, "gaps": "split",
            "signals": {
                "torque_ref": {"file": "log", "channel": "MotorTorqueSet", "unit": "N*m",
                               "quantity": "setpoint"},
                "motor_torque": {"file": "log", "channel": "MotorTorque", "unit": "N*m",
                                 "range": [-5000, 5000]},
                "speed_motor": {"file": "log", "channel": "MotorSpeed", "unit": "rpm"},
                "tacho": {"file": "log", "channel": "EncoderCount", "quantity": "tacho",
                          "tacho": "count", **(tacho or {"scale": 1 / COUNTS,
                                                          "pulses_per_rev": 1})}}}


@pytest.fixture(scope="module")
def logged(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("real")
    cols = logger_columns()
    write_interleaved(tmp / "run.tdms", cols)
    return tmp, cols


def _first_run(x: np.ndarray, value: float, n: int) -> tuple[int, int]:
    """First run of >= n samples equal to value: (start, length), by a plain loop."""
    k = 0
    while k < x.size:
        if x[k] == value:
            j = k
            while j < x.size and x[j] == value:
                j += 1
            if j - k >= n:
                return k, j - k
            k = j
        else:
            k += 1
    raise AssertionError("no run")


def test_values_read_equal_the_written_ones(logged):
    tmp, cols = logged
    ds = read(mapping(), tmp)
    stamps = ds.time.values + ds.attrs["record_start_s"]
    row = np.searchsorted(cols["Time"], stamps - 0.5 / FS)  # the nearest written row
    np.testing.assert_allclose(cols["Time"][row], stamps, rtol=0, atol=1e-9)
    # the dropped row and the clock jump cut the record into three gap-free segments
    assert np.unique(ds.segment.values).size == 3 and ds.time.size == ROWS - 1
    np.testing.assert_allclose(ds.torque_ref.values, cols["MotorTorqueSet"][row], rtol=1e-12)
    np.testing.assert_allclose(ds.motor_torque.values, cols["MotorTorque"][row], rtol=1e-12,
                               atol=1e-9)
    np.testing.assert_allclose(ds.speed_motor.values,
                               cols["MotorSpeed"][row] * 2 * np.pi / 60, rtol=1e-12)
    assert ds.speed_motor.attrs["units"] == "rad/s" and ds.torque_ref.attrs["units"] == "N m"


def test_dropped_row_bridged(tmp_path):
    """Without the clock jump, interpolate_upto: 1 bridges the dropped row with the
    straight line between its neighbours, and keeps every written row as written."""
    cols = logger_columns(jump=0.0)
    write_interleaved(tmp_path / "run.tdms", cols)
    spec = {**mapping(), "gaps": {"interpolate_upto": 1}}
    ds = read(spec, tmp_path)
    assert ds.time.size == ROWS and "segment" not in ds.coords
    t = ds.time.values + ds.attrs["record_start_s"]
    np.testing.assert_allclose(t, np.arange(ROWS) / FS, rtol=0, atol=1e-9)
    kept = np.delete(np.arange(ROWS), DROPPED)        # the written rows, in record samples
    np.testing.assert_allclose(ds.motor_torque.values[kept], cols["MotorTorque"],
                               rtol=1e-12, atol=1e-9)
    mid = 0.5 * (cols["MotorTorque"][DROPPED - 1] + cols["MotorTorque"][DROPPED])
    assert ds.motor_torque.values[DROPPED] == pytest.approx(mid, rel=1e-12)
    # the 250-sample clock jump is longer than the bridge: refused where it is
    write_interleaved(tmp_path / "run.tdms", logger_columns())
    with pytest.raises(DataError, match=rf"run.tdms: channel 'MotorTorqueSet' \(time\) at "
                       rf"sample {JUMP_AT - 1}: gap of 0.25 s \(250 missing"):
        read(spec, tmp_path)


def test_flat_tops_are_warnings_with_position(logged):
    tmp, cols = logged
    ds = read(mapping(), tmp)
    warned = json.loads(ds.attrs["check_warnings"])
    # the set-point rests at 0 between bursts: normal for a set-point, no warning
    assert "torque_ref" not in warned and "check_warnings" not in ds.torque_ref.attrs
    # the held speed: a warning at its first 50-sample run at the maximum and the minimum
    speed = cols["MotorSpeed"]
    text = ds.speed_motor.attrs["check_warnings"]
    assert "; ".join(warned["speed_motor"]) == text and len(warned["speed_motor"]) == 2
    for word, extreme in (("maximum", speed.max()), ("minimum", speed.min())):
        start, n = _first_run(speed, extreme, 5)
        assert n == HOLD
        assert (f"flat top of {HOLD} samples at the {word} {extreme:g} (3 such run(s)), "
                f"from sample {start} (t = {cols['Time'][start]:.9g} s") in text
    # the checks applied are recorded, per signal
    sources = json.loads(ds.attrs["signal_sources"])
    assert sources["torque_ref"]["checks"] == {"flat_top": "off", "range": "error"}
    assert sources["speed_motor"]["checks"] == {"flat_top": "warn", "range": "error"}
    assert ds.motor_torque.attrs["checks"] == "flat_top: warn, range: error"


def test_same_set_point_as_value_warns_and_checks_can_refuse(logged):
    tmp, cols = logged
    spec = mapping()
    spec["signals"]["torque_ref"]["quantity"] = "value"
    ds = read(spec, tmp)
    start, n = _first_run(cols["MotorTorqueSet"], 0.0, 5)
    assert (f"flat top of {n} samples at the minimum 0 (4 such run(s)), from sample {start} "
            f"(t = {cols['Time'][start]:.9g} s") in ds.torque_ref.attrs["check_warnings"]
    spec["signals"]["torque_ref"]["checks"] = {"flat_top": "off"}
    assert "check_warnings" not in read(spec, tmp).torque_ref.attrs
    spec["signals"]["speed_motor"]["checks"] = {"flat_top": "error"}
    with pytest.raises(DataError, match=r"run.tdms: channel 'MotorSpeed' at sample \d+: "
                       r"clipped: flat top of 50 samples.*quantity: setpoint"):
        read(spec, tmp)


def test_streamed_equals_in_memory(logged):
    tmp, _ = logged
    memory = read(mapping(), tmp)
    streamed = read(mapping(), tmp, out=tmp / "out" / "run.nc")
    for name in ("torque_ref", "motor_torque", "speed_motor", "pulse_time"):
        np.testing.assert_array_equal(streamed[name].values, memory[name].values)
    assert streamed.speed_motor.attrs["check_warnings"] == \
        memory.speed_motor.attrs["check_warnings"]
    assert streamed.attrs["check_warnings"] == memory.attrs["check_warnings"]


@pytest.mark.parametrize("tacho", [{"scale": 1 / COUNTS, "pulses_per_rev": 1},
                                   {"pulses_per_rev": COUNTS}],
                         ids=["per-rev", "per-count"])
def test_encoder_counter_as_tacho(logged, tacho):
    """Pulses at whole revolutions (scale: 1/1024) or at every count, each within one
    count of travel at the slowest speed of the true crossing; per count, their number
    is exactly the counts of each segment."""
    tmp, cols = logged
    ds = read(mapping(**tacho), tmp)
    pulses = ds.pulse_time.values + ds.attrs["record_start_s"]
    per_pulse = COUNTS // tacho["pulses_per_rev"]             # counts per pulse
    # true crossing times, by bisection on the closed-form angle
    marks = np.floor(revolutions(pulses) * COUNTS / per_pulse + 0.5) * per_pulse / COUNTS
    lo, hi = pulses - 2e-3, pulses + 2e-3
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        below = revolutions(mid) < marks
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    tol = 1.0 / (COUNTS * speed_rpm(np.array([1.5])).min() / 60)  # one count at 1400 rpm
    assert np.max(np.abs(pulses - 0.5 * (lo + hi))) < tol
    assert np.all(np.diff(pulses) > 0)
    if tacho["pulses_per_rev"] == COUNTS:
        t, count = cols["Time"], cols["EncoderCount"]
        cuts = np.flatnonzero(np.diff(t) > 1.5 / FS) + 1
        expected = sum(int(c[-1] - c[0]) for c in np.split(count, cuts))
        assert pulses.size == expected > 1_000_000 / 10


def test_encoder_angle_as_tacho(tmp_path):
    """A cumulative encoder angle in degrees: a pulse every 2π/ppr, exact to the
    linear-interpolation bound α dt² / (8 ω) at the bench's acceleration."""
    b = bench()
    write_csv(tmp_path / "e.csv", {"time": b.t, "enc": np.degrees(b.angle)})
    spec = {"files": {"e": {"path": "e.csv", "time": "time"}}, "sample_rate": 2000.0,
            "signals": {"tacho": {"file": "e", "channel": "enc", "unit": "deg",
                                  "quantity": "tacho", "tacho": "angle",
                                  "pulses_per_rev": PPR}}}
    ds = read(spec, tmp_path)
    true = b.pulses[(b.pulses > b.t[0]) & (b.pulses <= b.t[-1])]
    dt, accel, slowest = b.t[1] - b.t[0], 2.0 * 2 * np.pi * 3.0, 28.0  # s, rad/s², rad/s
    assert ds.pulse_time.size == true.size
    assert np.max(np.abs(ds.pulse_time.values - true)) <= accel * dt**2 / (8 * slowest)
    assert np.allclose(np.degrees(angle_true(b.t)), np.degrees(b.angle))


def test_inspect_suggests_interleaved(logged):
    tmp, _ = logged
    rows = list_channels(tmp / "run.tdms")
    assert [r["length"] for r in rows] == [9 * (ROWS - 1)]
    hint = rows[0]["hint"]
    assert "interleaved:" in hint and "9 (column 0 increases" in hint
    assert "hint: " in format_listing(rows)


def _refused(tmp, cols, spec, fragments):
    write_interleaved(tmp / "run.tdms", cols)
    with pytest.raises(DataError) as info:
        read(spec, tmp)
    for frag in fragments:
        assert re.search(frag, str(info.value)), f"{frag!r} not in: {info.value}"


def test_real_refusals_stay(tmp_path):
    cols = logger_columns()
    spec = mapping()
    spec["signals"]["motor_torque"]["range"] = [-5000, 1000]
    first = int(np.flatnonzero(cols["MotorTorque"] >= 1000)[0])
    _refused(tmp_path, cols, spec, ["run.tdms", "channel 'MotorTorque'", f"sample {first}",
                                    "field 'range'", "lower the gain or widen its range"])
    bad = {**cols, "MotorTorque": cols["MotorTorque"].copy()}
    bad["MotorTorque"][1234] = np.nan
    _refused(tmp_path, bad, mapping(), ["run.tdms", "channel 'MotorTorque'", "sample 1234",
                                        "NaN", "interpolate_upto"])
    back = {**cols, "Time": cols["Time"].copy()}
    back["Time"][3000:] -= 1.0
    # a clock set back: refused where gaps are (with gaps: split a new segment:
    # test_clock_reset.py)
    _refused(tmp_path, back, {**mapping(), "gaps": "refuse"},
             ["run.tdms", r"channel '\w+' \(time\)", "sample 3000", "backwards",
              "gaps: split"])
    angle = {**cols, "EncoderCount": cols["EncoderCount"] + 0.37}
    _refused(tmp_path, angle, mapping(), ["run.tdms", "channel 'EncoderCount'",
                                          "field 'tacho'", "sample 0", "not a whole count",
                                          "tacho: angle"])
    _refused(tmp_path, cols, {**mapping(), "files": {"log": {
        "path": "run.tdms", "interleaved": COLUMNS[:8], "time": "Time"}}},
        ["run.tdms", "not a multiple of 8 columns", "interleaved:"])


@pytest.mark.parametrize("checks, key", [({"flat_top": "loud"}, "flat_top"),
                                         ({"flattop": "off"}, "flattop")])
def test_checks_key_is_checked(logged, checks, key):
    tmp, _ = logged
    spec = mapping()
    spec["signals"]["speed_motor"]["checks"] = checks
    with pytest.raises(ConfigError, match=f"measured.record.signals.speed_motor.checks.{key}"):
        read(spec, tmp)


def test_spectra_and_tsa_failures_name_record_signal_fix():
    """Three pulses in a record: spectra and TSA cannot work; the errors say which
    record, which signal, what the tacho gives and what to check."""
    cfg = load(CONFIG, CI_CONFIG)
    t = np.arange(4000) / FS
    ds = xr.Dataset({"torque_meter": ("time", np.sin(t), {"units": "N m", "long_name": "x"}),
                     "pulse_time": ("pulse", np.array([0.5, 1.5, 2.5]), {"units": "s"})},
                    coords={"time": ("time", t, {"units": "s"})},
                    attrs={"record_kind": "measured", "record": "bench7",
                           "sample_rate": FS, "pulses_per_rev": 1})
    with pytest.raises(DataError, match=r"record 'bench7': signal\(s\) torque_meter: spectra "
                       r"failed: .*3 pulses over 2 s at 1 per rev: 60 rpm.*pulses_per_rev"):
        sweep_waterfalls(ds, {**cfg["spectra"], "signal": "torque_meter"})
    with pytest.raises(DataError, match=r"record 'bench7': signal\(s\) torque_meter: TSA "
                       r"failed: .*scale:"):
        record_residuals(ds, ["torque_meter"], cfg["gearbox"]["stages"], cfg["tsa"], 0.0)
