"""Atomic outputs, their permissions, stale temporaries and source-file provenance."""

from __future__ import annotations

import csv
import hashlib
import json
import os
import stat

import numpy as np
import pytest
import xarray as xr

from gbpipe import io


def _ds() -> xr.Dataset:
    return xr.Dataset({"x": ("n", np.arange(4.0), {"units": "N m", "long_name": "torque"})},
                      coords={"n": ("n", np.arange(4), {"units": "1", "long_name": "index"})})


@pytest.fixture(autouse=True)
def _usual_umask():
    old = os.umask(0o022)
    yield
    os.umask(old)


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def test_every_kind_of_output_is_0644(tmp_path):
    nc = io.write(_ds(), tmp_path / "a.nc", stage="unit")
    table = io.write_csv([{"a": 1, "b": 2.5}], tmp_path / "t.csv")
    with io.atomic_path(tmp_path / "c.rst") as tmp:
        tmp.write_text("caption\n")
    assert {_mode(p) for p in (nc, table, tmp_path / "c.rst")} == {0o644}


def test_csv_columns_in_first_seen_order_and_values(tmp_path):
    path = io.write_csv([{"a": 1, "b": 2}, {"b": 3, "c": "x"}], tmp_path / "t.csv")
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows == [["a", "b", "c"], ["1", "2", ""], ["", "3", "x"]]


def test_failed_write_leaves_old_file_and_no_temporary(tmp_path):
    target = tmp_path / "keep.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError), io.atomic_path(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("job died")
    assert target.read_text() == "old"
    assert list(tmp_path.iterdir()) == [target]


def test_clean_temporaries_removes_only_what_a_killed_job_left(tmp_path):
    (tmp_path / "sub").mkdir()
    keep = [tmp_path / "a.nc", tmp_path / "sub" / ".hidden.nc", tmp_path / "sub" / "b.tmp"]
    for p in keep:
        p.write_text("output")
    # what atomic_path makes, and what SIGKILL would leave: the temporary, never renamed
    ctx = io.atomic_path(tmp_path / "sub" / "c.nc")
    orphan = ctx.__enter__()
    orphan.write_text("half")
    removed = io.clean_temporaries(tmp_path)
    assert removed == [orphan]
    assert all(p.exists() for p in keep) and not orphan.exists()
    assert io.clean_temporaries(tmp_path / "missing") == []


def test_source_files_carry_size_and_independent_sha256(tmp_path):
    data = os.urandom(3 * (1 << 20) + 17)  # more than one hashing block
    src = tmp_path / "bench.tdms"
    src.write_bytes(data)
    path = io.write(_ds(), tmp_path / "a.nc", stage="unit", sources=[src, tmp_path])
    files = json.loads(io.read(path).attrs["source_files"])
    assert files == [{"path": str(src), "bytes": len(data),
                      "sha256": hashlib.sha256(data).hexdigest()}]


def test_config_slice_is_stored_and_hashes_to_config_sha256(tmp_path):
    cfg = {"tsa": {"n_cycles": 10}, "seed": 3}
    attrs = io.read(io.write(_ds(), tmp_path / "a.nc", stage="unit", config=cfg)).attrs
    assert json.loads(attrs["config"]) == cfg
    assert io.config_sha256(json.loads(attrs["config"])) == attrs["config_sha256"]
