"""Long records: ``read(..., out=path)`` reads, checks and resamples block by block into a
NetCDF file. Its values, attributes and refusals must be those of the in-memory reader
(an independent path through the same record: whole arrays, one-shot filters), with
absolute sample indices, and a failure must leave no file.

Every test makes the blocks small (hundreds of samples), so a record of a few thousand
samples spans many blocks, and blocks' edges fall inside gaps, NaN runs and filters."""

from __future__ import annotations

import hashlib
import json
import re

import numpy as np
import pytest
from measured_bench import bench, write_csv, write_tdms, write_tdms_array_column
from nptdms import ChannelObject, TdmsWriter
from test_malformed import CASES, mdf_without_asammdf

import gbpipe
from gbpipe.errors import DataError
from gbpipe.io import config_sha256
from gbpipe.measured import checks, read, stream
from gbpipe.measured.formats import delimited, tdms
from gbpipe.measured.resample import BlockResampler
from gbpipe.measured.spec import parse
from gbpipe.measured.timebase import Piece, resample

RTOL = 1e-9


@pytest.fixture(autouse=True)
def small_blocks(monkeypatch):
    monkeypatch.setattr(checks, "BLOCK", 1000)
    monkeypatch.setattr(stream, "OUT_BLOCK", 500)
    monkeypatch.setattr(tdms, "BLOCK", 900)
    monkeypatch.setattr(delimited, "CHUNK", 800)


def _same(ds, dz):
    """Streamed ``dz`` holds the values and attributes of the in-memory ``ds``."""
    assert set(ds.variables) == set(dz.variables)
    for name, var in ds.variables.items():
        a, b = var.values, dz[name].values
        assert a.shape == b.shape, name
        if a.dtype.kind == "f":
            np.testing.assert_allclose(b, a, rtol=RTOL, atol=RTOL * np.abs(a).max(),
                                       err_msg=name)
        else:
            np.testing.assert_array_equal(b, a, err_msg=name)
        for key in ("units", "long_name", "pulses_per_rev"):
            assert var.attrs.get(key) == dz[name].attrs.get(key), (name, key)
    for key, value in ds.attrs.items():
        if isinstance(value, float):
            assert dz.attrs[key] == pytest.approx(value, rel=1e-12, abs=1e-12), key
        else:
            assert dz.attrs[key] == value, key


def _interleaved(path, n, fs, start):
    """NI_ArrayColumn TDMS: two columns interleaved in column 0 (kN*m and V)."""
    t = start + np.arange(n) / fs
    cols = np.column_stack([1.0 + 0.05 * np.sin(2 * np.pi * 41 * t),
                            2.5 + np.sin(2 * np.pi * 7 * t)])
    props = {"wf_increment": 1.0 / fs, "wf_start_offset": start}
    with TdmsWriter(path) as w:
        w.write_segment([
            ChannelObject("A", "Torque", cols.ravel(), properties={
                **props, "NI_ArrayColumn": np.int32(0), "unit_string": "kN*m"}),
            ChannelObject("A", "Volt", np.array([], dtype=float), properties={
                **props, "NI_ArrayColumn": np.int32(1), "unit_string": "V"})])


def _record(tmp, rate):
    """TDMS (2 kHz from 0.1 s, torque and tacho), an NI_ArrayColumn TDMS (4 kHz from
    0.05 s), a CSV (3 kHz from 0.25 s, jittered stamps, torque and an encoder angle)."""
    b = bench(n=6000)
    write_tdms(tmp / "daq.tdms", b, start_offset=0.1, epoch=None, segments=5)
    _interleaved(tmp / "arr.tdms", 11000, 4000.0, 0.05)
    rng = np.random.default_rng(7)
    n, fs = 8000, 3000.0
    t = 0.25 + np.arange(n) / fs
    stamps = t + rng.uniform(-0.3, 0.3, n) / fs
    write_csv(tmp / "log.csv", {"time": stamps,
                                "torque [N*m]": 500 + 20 * np.sin(2 * np.pi * 50 * t)
                                + rng.standard_normal(n),
                                "encoder [deg]": np.degrees(30 * t + 0.1 * np.sin(9 * t))})
    return {"files": {"daq": {"path": "daq.tdms"}, "arr": {"path": "arr.tdms"},
                      "log": {"path": "log.csv", "time": "time"}},
            "sample_rate": rate,
            "signals": {"meter": {"file": "daq", "channel": "Measurements/Torque"},
                        "array_torque": {"file": "arr", "channel": "A/Torque"},
                        "array_volt": {"file": "arr", "channel": "A/Volt", "scale": 2.0},
                        "motor": {"file": "log", "channel": "torque"},
                        "speed": {"file": "log", "channel": "encoder", "quantity": "angle"},
                        "tacho": {"file": "daq", "channel": "Measurements/Tacho",
                                  "quantity": "tacho", "pulses_per_rev": 8}}}


@pytest.mark.parametrize("rate", [1000.0, 2000.0, 1234.5678])
def test_streamed_equals_in_memory(tmp_path, rate):
    """Polyphase + fractional delay (1000, 2000 Hz) and band-limited (1234.5678 Hz)."""
    spec = _record(tmp_path, rate)
    ds = read(spec, tmp_path, name="run1")
    cfg = {"measured": {"run1": spec}}
    out = tmp_path / "results" / "run1.nc"
    dz = read(spec, tmp_path, name="run1", out=out,
              provenance={"config": cfg, "wildcards": {"record": "run1"}})
    assert ds.sizes["time"] > 5 * stream.OUT_BLOCK
    _same(ds, dz)
    assert dz.attrs["config_sha256"] == config_sha256(cfg)
    assert dz.attrs["gbpipe_version"] == gbpipe.__version__
    assert dz.attrs["wildcard_record"] == "run1"
    for entry in json.loads(dz.attrs["source_files"]):
        data = (tmp_path / entry["path"].split("/")[-1]).read_bytes()
        assert entry["sha256"] == hashlib.sha256(data).hexdigest()
        assert entry["bytes"] == len(data)
    dz.close()


@pytest.mark.parametrize(("up", "down", "offset"), [(1, 1, 0.0), (1, 1, 0.3), (2, 3, 0.0),
                                                    (3, 2, 0.37), (7, 5, 0.0), (0, 0, 0.2)])
def test_block_resampler_matches_one_shot(up, down, offset):
    """Any block partition, at the piece's ends too (padtype='line' continuation)."""
    rng = np.random.default_rng(up * 10 + down)
    x = np.cumsum(rng.standard_normal(3001))
    dt = 1e-3
    fs = up / down / dt if up else 737.123
    piece = Piece(x, 0.5, dt)
    start = 0.5 + offset / fs
    n = int(np.floor((piece.end - start) * fs)) + 1
    ref = resample(piece, start, fs, n)
    blockwise = BlockResampler(lambda i, j: x[i:j].copy(), x.size, piece.t0, dt, start, fs,
                               n)
    cuts = np.unique(np.concatenate([[0, n], rng.integers(1, n, 9), [1, n - 1]]))
    got = np.concatenate([blockwise(a, b) for a, b in zip(cuts[:-1], cuts[1:], strict=True)])
    np.testing.assert_allclose(got, ref, rtol=RTOL, atol=RTOL * np.abs(ref).max())


def _csv_spec(tmp, time, torque, **record):
    write_csv(tmp / "s.csv", {"time": time, "torque": torque})
    return {"files": {"s": {"path": "s.csv", "time": "time"}}, "sample_rate": 1000.0,
            "signals": {"torque": {"file": "s", "channel": "torque", "unit": "N*m"}},
            **record}


def _refusal(spec, tmp, **kw):
    """The streamed and the in-memory refusals of ``spec`` (same message), and nothing
    written."""
    out = tmp / "res" / "r.nc"
    with pytest.raises(DataError) as streamed:
        read(spec, tmp, out=out, **kw)
    with pytest.raises(DataError) as memory:
        read(spec, tmp, **kw)
    assert not out.parent.exists() or not any(out.parent.iterdir())
    return streamed.value, memory.value


T = np.arange(6000) / 1000.0
X = 100.0 + np.sin(2 * np.pi * 13 * T)


def test_nan_in_third_block_has_absolute_index(tmp_path):
    x = X.copy()
    x[2345:2347] = np.nan  # block 3 of 1000 samples
    streamed, memory = _refusal(_csv_spec(tmp_path, T, x), tmp_path)
    assert streamed.sample == memory.sample == 2345
    assert str(streamed) == str(memory)
    assert re.search(r"s\.csv.*channel 'torque'.*2 NaN/inf sample\(s\); 2 in all", str(streamed))


def test_nan_in_third_block_of_tdms(tmp_path):
    x = X.copy()
    x[2345] = np.nan
    with TdmsWriter(tmp_path / "n.tdms") as w:
        for idx in np.array_split(np.arange(x.size), 4):
            w.write_segment([ChannelObject("G", "T", x[idx], properties={
                "wf_increment": 1e-3, "unit_string": "N*m"})])
    spec = {"files": {"n": "n.tdms"}, "sample_rate": 1000.0,
            "signals": {"torque": {"file": "n", "channel": "G/T"}}}
    streamed, memory = _refusal(spec, tmp_path)
    assert streamed.sample == memory.sample == 2345 and str(streamed) == str(memory)
    assert "n.tdms: channel 'G/T'" in str(streamed)


def test_gap_in_third_block_has_absolute_index(tmp_path):
    t = np.concatenate([T[:2500], T[2500:] + 0.05])  # 50 missing samples after 2499
    streamed, memory = _refusal(_csv_spec(tmp_path, t, X), tmp_path)
    assert streamed.sample == memory.sample == 2500
    assert "gap of 0.05 s (50 missing samples)" in str(streamed) == str(memory)
    spec = _csv_spec(tmp_path, t, X, gaps="split")
    ds = read(spec, tmp_path)
    dz = read(spec, tmp_path, out=tmp_path / "split.nc")
    assert np.bincount(dz["segment"].values).tolist() == [2500, 3500]
    _same(ds, dz)


def test_clock_jump_and_jitter_in_third_block(tmp_path):
    t = T.copy()
    t[2700:] -= 1.0  # clock reset
    streamed, memory = _refusal(_csv_spec(tmp_path, t, X), tmp_path)
    assert streamed.sample == memory.sample == 2700 and str(streamed) == str(memory)
    t = T.copy()
    t[2222] += 0.0006  # 0.6 sample off the clock
    streamed, memory = _refusal(_csv_spec(tmp_path, t, X), tmp_path)
    assert streamed.sample == memory.sample == 2222
    assert "deviate from a uniform clock" in str(streamed)


def test_runs_across_block_edges(tmp_path):
    """A NaN run bridged across a block edge equals the in-memory bridge; a flat top
    across a block edge is found at its first sample."""
    x = X.copy()
    x[999:1002] = np.nan
    spec = _csv_spec(tmp_path, T, x, gaps={"interpolate_upto": 3})
    spec["files"]["s"] = {"path": "s.csv", "sample_rate": 1000.0}  # streamable
    assert stream.streamable(parse(spec))
    _same(read(spec, tmp_path), read(spec, tmp_path, out=tmp_path / "bridged.nc"))
    x = X.copy()
    x[1997:2004] = X.max() + 1.0
    spec = _csv_spec(tmp_path, T, x)
    # by default a warning, with the same position in the streamed and in-memory records
    warned = [read(spec, tmp_path).torque.attrs["check_warnings"],
              read(spec, tmp_path, out=tmp_path / "warned.nc").torque.attrs["check_warnings"]]
    assert warned[0] == warned[1]
    assert "flat top of 7 samples" in warned[0] and "from sample 1997 (t = 1.997 s" in warned[0]
    spec["signals"]["torque"]["checks"] = {"flat_top": "error"}
    streamed, memory = _refusal(spec, tmp_path)
    assert streamed.sample == memory.sample == 1997
    assert "flat top of 7 samples" in str(streamed) == str(memory)


def test_failure_midway_leaves_no_file(tmp_path, monkeypatch):
    spec = _csv_spec(tmp_path, T, X)
    out = tmp_path / "res" / "r.nc"
    out.parent.mkdir()
    calls = []

    def fail_third(self, a, b):
        calls.append(a)
        if len(calls) == 3:
            raise OSError("disk full")
        return original(self, a, b)

    original = BlockResampler.__call__
    monkeypatch.setattr(BlockResampler, "__call__", fail_third)
    with pytest.raises(OSError, match="disk full"):
        read(spec, tmp_path, out=out)
    assert list(out.parent.iterdir()) == []  # no output, no temporary, no template
    out.write_bytes(b"previous result")
    calls.clear()
    with pytest.raises(OSError, match="disk full"):
        read(spec, tmp_path, out=out)
    assert out.read_bytes() == b"previous result"


@pytest.mark.parametrize("case", CASES, ids=[c.__name__ for c in CASES])
def test_malformed_refused_when_streamed(case, tmp_path, monkeypatch):
    """The malformed inputs of test_malformed, through ``out=``: the same error class
    and message fragments, and no file."""
    args = (tmp_path, monkeypatch) if case is mdf_without_asammdf else (tmp_path,)
    spec, exc, fragments, *kw = case(*args)
    out = tmp_path / "results" / "r.nc"
    with pytest.raises(exc) as info:
        read(spec, tmp_path, out=out, **(kw[0] if kw else {}))
    for frag in fragments:
        assert re.search(frag, str(info.value)), f"{frag!r} not in: {info.value}"
    assert not out.parent.exists() or not any(out.parent.iterdir())


def test_array_column_streamed_like_in_memory(tmp_path):
    """The NI_ArrayColumn layout of the round-trip tests, through ``out=``."""
    b = bench(n=4000)
    write_tdms_array_column(tmp_path / "a.tdms", b)
    spec = {"files": {"a": "a.tdms"}, "sample_rate": 2000.0,
            "signals": {"torque": {"file": "a", "channel": "Array/Torque"},
                        "volt": {"file": "a", "channel": "Array/Tacho"}}}
    dz = read(spec, tmp_path, out=tmp_path / "a.nc")
    np.testing.assert_array_equal(dz["torque"].values, b.torque)
    np.testing.assert_array_equal(dz["volt"].values, b.tacho)


def test_time_gap_bridging_falls_back_to_memory(tmp_path):
    """Bridging a time gap inserts samples: read in memory, then written with
    gbpipe.io.write (same values, same provenance attributes)."""
    t = np.concatenate([T[:3000], T[3002:]])  # 2 missing samples
    spec = _csv_spec(tmp_path, t, np.interp(t, T, X), gaps={"interpolate_upto": 2})
    assert not stream.streamable(parse(spec))
    dz = read(spec, tmp_path, out=tmp_path / "f.nc", provenance={"config": spec})
    _same(read(spec, tmp_path), dz)
    assert dz.sizes["time"] == T.size and dz.attrs["config_sha256"] == config_sha256(spec)
