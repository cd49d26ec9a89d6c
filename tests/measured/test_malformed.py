"""Malformed inputs: each is refused before any output, with a message naming the file,
the channel and the field (or the mapping's key path), and the sample where there is one."""

from __future__ import annotations

import re
import sys

import numpy as np
import pytest
import pyuff
from measured_bench import FS, bench, write_csv, write_mat, write_tdms, write_uff

from gbpipe.errors import ConfigError, DataError
from gbpipe.measured import read

B = bench(n=1000, noise=0.0)
TORQUE = {"file": "s", "channel": "torque", "unit": "N*m"}


def _csv(tmp, name="s.csv", **cols):
    cols = cols or {"time": B.t, "torque": B.torque}
    write_csv(tmp / name, cols)
    return name


def _spec(path, signals=None, **file_opts):
    return {"files": {"s": {"path": path, "time": "time", **file_opts}},
            "sample_rate": FS, "signals": signals or {"torque": TORQUE}}


def missing_file(tmp):
    return _spec("nope.csv"), DataError, ["nope.csv", "field 'path'", "no such file"]


def missing_channel(tmp):
    return (_spec(_csv(tmp), {"torque": {**TORQUE, "channel": "torqe"}}), DataError,
            ["s.csv", "channel 'torqe'", "Did you mean 'torque'"])


def non_monotonic_time(tmp):
    t = B.t.copy()
    t[[500, 501]] = t[[501, 500]]
    return (_spec(_csv(tmp, time=t, torque=B.torque)), DataError,
            ["s.csv", "channel 'torque'", r"\(time\) at sample 501", "not monotonic"])


def time_gap(tmp):
    t = np.concatenate([B.t[:400], B.t[400:] + 0.1])
    return (_spec(_csv(tmp, time=t, torque=B.torque)), DataError,
            ["s.csv", "channel 'torque'", "sample 400", "gap of 0.1 s", "200 missing"])


def backward_clock_jump(tmp):
    t = np.concatenate([B.t[:600], B.t[:400]])
    return (_spec(_csv(tmp, time=t, torque=B.torque)), DataError,
            ["s.csv", "channel 'torque'", "sample 600", "backwards by 0.2995 s",
             "clock reset"])


def duplicate_stamp(tmp):
    t = B.t.copy()
    t[300] = t[299]
    return (_spec(_csv(tmp, time=t, torque=B.torque)), DataError,
            ["s.csv", "channel 'torque'", "sample 300", "repeats"])


def nan_values(tmp):
    x = B.torque.copy()
    x[123:125] = np.nan
    return (_spec(_csv(tmp, time=B.t, torque=x)), DataError,
            ["s.csv", "channel 'torque'", "sample 123", "2 NaN"])


def nan_longer_than_bridge(tmp):
    x = B.torque.copy()
    x[200:210] = np.nan
    spec = {**_spec(_csv(tmp, time=B.t, torque=x)), "gaps": {"interpolate_upto": 3}}
    return spec, DataError, ["s.csv", "channel 'torque'", "sample 200", "interpolate_upto"]


def nan_in_time(tmp):
    t = B.t.copy()
    t[50] = np.nan
    return (_spec(_csv(tmp, time=t, torque=B.torque)), DataError,
            ["s.csv", "channel 'torque'", r"\(time\) at sample 50", "NaN"])


def clipping_flat_top(tmp):
    """A flat top is an error only when the signal's checks say so."""
    x = np.minimum(B.torque, 1040.0)
    first = int(np.flatnonzero(x == 1040.0)[0])
    spec = _spec(_csv(tmp, time=B.t, torque=x),
                 {"torque": {**TORQUE, "checks": {"flat_top": "error"}}})
    return (spec, DataError, ["s.csv", "channel 'torque'", "clipped", "flat top",
                              f"at sample {first}", f"t = {B.t[first]:.9g} s",
                              "quantity: setpoint"])


def clipping_converter_range(tmp):
    first = int(np.flatnonzero(B.torque >= 1050)[0])
    return (_spec(_csv(tmp), {"torque": {**TORQUE, "range": [0, 1050]}}), DataError,
            ["s.csv", "channel 'torque'", "field 'range'", f"at sample {first}",
             "lower the gain or widen its range"])


def unknown_unit(tmp):
    return (_spec(_csv(tmp), {"torque": {**TORQUE, "unit": "furlongz"}}), DataError,
            ["s.csv", "channel 'torque'", "field 'unit'", "unknown unit 'furlongz'"])


def unit_without_si(tmp):
    return (_spec(_csv(tmp), {"torque": {**TORQUE, "unit": "N*m*s**3"}}), DataError,
            ["s.csv", "channel 'torque'", "field 'unit'", "no SI unit"])


def no_unit_anywhere(tmp):
    return (_spec(_csv(tmp), {"torque": {"file": "s", "channel": "torque"}}), DataError,
            ["s.csv", "channel 'torque'", "field 'unit'", "add unit"])


def angle_with_torque_unit(tmp):
    return (_spec(_csv(tmp), {"speed": {**TORQUE, "quantity": "angle"}}), DataError,
            ["s.csv", "channel 'torque'", "field 'unit'", "angle unit"])


def no_overlap(tmp):
    _csv(tmp, "a.csv", time=B.t, torque=B.torque)
    _csv(tmp, "b.csv", time=B.t + 10.0, torque=B.torque)
    spec = {"files": {"a": {"path": "a.csv", "time": "time"},
                      "b": {"path": "b.csv", "time": "time"}}, "sample_rate": FS,
            "signals": {"x": {**TORQUE, "file": "a"}, "y": {**TORQUE, "file": "b"}}}
    return spec, DataError, ["do not overlap", r"a\.csv: channel 'torque': \[0, 0.4995\]",
                             r"b\.csv: channel 'torque': \[10, 10.4995\]"]


def mapping_typo(tmp):
    return (_spec(_csv(tmp), {"torque": {**TORQUE, "chanel": "torque"}}), ConfigError,
            [r"measured\.record\.signals\.torque\.chanel", "did you mean 'channel'"])


def record_key_typo(tmp):
    spec = {**_spec(_csv(tmp)), "sample_rte": FS}
    return spec, ConfigError, [r"measured\.record\.sample_rte", "did you mean 'sample_rate'"]


def unknown_file_key(tmp):
    return (_spec(_csv(tmp), {"torque": {**TORQUE, "file": "sensor"}}), ConfigError,
            [r"signals\.torque\.file", "'sensor' is not a key of files"])


def tacho_without_ppr(tmp):
    return (_spec(_csv(tmp), {"t": {**TORQUE, "quantity": "tacho"}}), ConfigError,
            [r"signals\.t\.pulses_per_rev", "positive integer"])


def bad_gap_policy(tmp):
    return {**_spec(_csv(tmp)), "gaps": "bridge"}, ConfigError, [r"record\.gaps", "bridge"]


def negative_rate(tmp):
    return {**_spec(_csv(tmp)), "sample_rate": -5}, ConfigError, ["sample_rate", "positive"]


def empty_file(tmp):
    (tmp / "e.csv").write_bytes(b"")
    return _spec("e.csv"), DataError, ["e.csv", "empty"]


def truncated_tdms(tmp):
    write_tdms(tmp / "r.tdms", B, segments=1)
    data = (tmp / "r.tdms").read_bytes()
    (tmp / "r.tdms").write_bytes(data[: len(data) // 2])
    spec = {"files": {"d": "r.tdms"}, "sample_rate": FS,
            "signals": {"torque": {"file": "d", "channel": "Measurements/Torque"}}}
    return spec, DataError, ["r.tdms", "truncated"]


def not_a_tdms(tmp):
    (tmp / "x.tdms").write_bytes(b"this is no TDMS file" * 10)
    spec = {"files": {"d": "x.tdms"}, "sample_rate": FS,
            "signals": {"torque": {"file": "d", "channel": "Measurements/Torque"}}}
    return spec, DataError, ["x.tdms", "not a readable TDMS"]


def tdms_missing_channel(tmp):
    write_tdms(tmp / "r.tdms", B)
    spec = {"files": {"d": "r.tdms"}, "sample_rate": FS,
            "signals": {"torque": {"file": "d", "channel": "Torque"}}}
    return spec, DataError, ["r.tdms", "channel 'Torque'", "Measurements/Torque"]


def wrong_delimiter(tmp):
    write_csv(tmp / "s.csv", {"time": B.t, "torque": B.torque}, sep=";")
    return _spec("s.csv", delimiter=","), DataError, ["s.csv", "field 'delimiter'", "';'"]


def decimal_comma_undeclared(tmp):
    write_csv(tmp / "s.csv", {"time": B.t, "torque": B.torque}, sep=";", decimal=",")
    return _spec("s.csv"), DataError, ["s.csv", "channel '(time|torque)'", "not a number",
                                       "decimal"]


def no_time_base(tmp):
    spec = _spec(_csv(tmp))
    del spec["files"]["s"]["time"]
    return spec, DataError, ["s.csv", "channel 'torque'", "time:", "sample_rate:"]


def missing_time_channel(tmp):
    return _spec(_csv(tmp), time="Time_s"), DataError, ["s.csv", "field 'time'", "Time_s"]


def unknown_suffix(tmp):
    (tmp / "r.xyz").write_text("a,b\n1,2\n")
    return _spec("r.xyz"), DataError, ["r.xyz", "field 'path'", "format:"]


def unknown_format(tmp):
    return _spec(_csv(tmp), format="excel"), DataError, ["s.csv", "field 'format'", "excel"]


def too_short(tmp):
    return (_spec(_csv(tmp)), DataError, ["record 'record'", "too short", "0.5 s", "1000 samples"],
            {"min_duration": 10.0})


def irregular_sampling(tmp):
    t = np.cumsum(np.random.default_rng(0).uniform(0.2, 1.7, B.t.size)) / FS
    return (_spec(_csv(tmp, time=t, torque=B.torque)), DataError,
            ["s.csv", "channel 'torque'", "irregular sampling", "at sample"])


def uff_spectrum_not_time(tmp):
    d = pyuff.prepare_58(binary=0, id1="FRF", func_type=4, rsp_node=1, rsp_dir=1,
                         ref_node=1, ref_dir=1, data=np.ones(10) + 1j, x=np.arange(10.0),
                         abscissa_spacing=1, abscissa_spec_data_type=18,
                         ordinate_spec_data_type=12, orddenom_spec_data_type=13)
    pyuff.UFF(str(tmp / "f.uff")).write_sets([d], mode="overwrite")
    spec = {"files": {"u": "f.uff"}, "sample_rate": FS,
            "signals": {"x": {"file": "u", "channel": "FRF", "unit": "N"}}}
    return spec, DataError, ["f.uff", "channel 'FRF'", "field 'func_type'"]


def uff_missing_set(tmp):
    write_uff(tmp / "r.uff", B)
    spec = {"files": {"u": "r.uff"}, "sample_rate": FS,
            "signals": {"x": {"file": "u", "channel": "#7"}}}
    return spec, DataError, ["r.uff", "channel '#7'", "Torque"]


def mat_column_out_of_range(tmp):
    write_mat(tmp / "m.mat", B)
    spec = {"files": {"m": {"path": "m.mat", "sample_rate": FS}}, "sample_rate": FS,
            "signals": {"x": {"file": "m", "channel": "both[:, 5]", "unit": "V"}}}
    return spec, DataError, ["m.mat", r"channel 'both\[:, 5\]'", r"both\[:, 1\]"]


def tacho_threshold_outside(tmp):
    write_tdms(tmp / "r.tdms", B)
    spec = {"files": {"d": "r.tdms"}, "sample_rate": FS,
            "signals": {"t": {"file": "d", "channel": "Measurements/Tacho",
                              "quantity": "tacho", "pulses_per_rev": 8,
                              "threshold": 50.0}}}
    return spec, DataError, ["r.tdms", "channel 'Measurements/Tacho'", "field 'threshold'"]


def empty_channel(tmp):
    (tmp / "s.csv").write_text("time,torque\n")
    return _spec("s.csv"), DataError, ["s.csv", "channel 'torque'", "no samples"]


def mdf_without_asammdf(tmp, monkeypatch):
    (tmp / "r.mf4").write_bytes(b"MDF     4.10    ")
    monkeypatch.setitem(sys.modules, "asammdf", None)  # import asammdf -> ImportError
    spec = {"files": {"m": "r.mf4"}, "sample_rate": FS,
            "signals": {"x": {"file": "m", "channel": "Torque", "unit": "N*m"}}}
    return spec, DataError, ["r.mf4", r"pip install gbpipe\[mdf\]"]


CASES = [missing_file, missing_channel, non_monotonic_time, time_gap, backward_clock_jump,
         duplicate_stamp, nan_values, nan_longer_than_bridge, nan_in_time,
         clipping_flat_top, clipping_converter_range, unknown_unit, unit_without_si,
         no_unit_anywhere, angle_with_torque_unit, no_overlap, mapping_typo,
         record_key_typo, unknown_file_key, tacho_without_ppr, bad_gap_policy,
         negative_rate, empty_file, truncated_tdms, not_a_tdms, tdms_missing_channel,
         wrong_delimiter, decimal_comma_undeclared, no_time_base, missing_time_channel,
         unknown_suffix, unknown_format, too_short, irregular_sampling,
         uff_spectrum_not_time, uff_missing_set, mat_column_out_of_range,
         tacho_threshold_outside, empty_channel, mdf_without_asammdf]


@pytest.mark.parametrize("case", CASES, ids=[c.__name__ for c in CASES])
def test_refused(case, tmp_path, monkeypatch):
    args = (tmp_path, monkeypatch) if case is mdf_without_asammdf else (tmp_path,)
    spec, exc, fragments, *kw = case(*args)
    before = sorted(p.name for p in tmp_path.rglob("*"))
    with pytest.raises(exc) as info:
        read(spec, tmp_path, **(kw[0] if kw else {}))
    message = str(info.value)
    for frag in fragments:
        assert re.search(frag, message), f"{frag!r} not in: {message}"
    assert sorted(p.name for p in tmp_path.rglob("*")) == before  # nothing written


def test_enough_cases():
    assert len(CASES) >= 25
