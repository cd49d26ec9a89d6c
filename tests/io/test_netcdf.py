"""The one NetCDF writer and reader: round trip, refusals, atomicity, provenance."""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import os

import cf_units
import netCDF4
import numpy as np
import pytest
import xarray as xr

import gbpipe
from gbpipe import io


def _dataset() -> xr.Dataset:
    """A small dataset with every feature the writer has to transform for CF."""
    rng = np.random.default_rng(1)
    t = np.arange(50) / 100.0
    names = ["speed", "torque", "angle"]
    ds = xr.Dataset(
        {
            "torque": ("time", rng.normal(size=t.size),
                       {"units": "N m", "long_name": "torque", "comment": "a producer note"}),
            "rpm": ("time", 1000.0 + t, {"units": "rev/min", "long_name": "shaft speed"}),
            "gain_db": ("row", [-3.0, 0.0, 6.0], {"units": "dB", "long_name": "gain"}),
            "matrix": (("row", "order"), rng.normal(size=(3, 4)),
                       {"units": "mixed (see row_units)", "long_name": "a matrix"}),
            "count": ("order", np.array([4, 1, 3, 2], dtype=np.int64),
                      {"units": "1", "long_name": "counts"}),
        },
        coords={
            "time": ("time", t, {"units": "s", "long_name": "time from record start"}),
            "row": ("row", names, {"units": "1", "long_name": "row name"}),
            "row_units": ("row", ["rad/s", "N m", "rad"], {"units": "1",
                                                           "long_name": "unit of the row"}),
            # unsorted numbers: not a CF coordinate variable either
            "order": ("order", [2.0, 1.0, 3.0, 0.5], {"units": "1", "long_name": "order"}),
        },
        attrs={"note": "kept", "flags": [1, 2], "history": "2020-01-01: made by hand"},
    )
    return ds


def test_round_trip_values_attrs_and_time(tmp_path):
    ds = _dataset()
    path = io.write(ds, tmp_path / "a.nc", stage="unit", config={"a": 1})
    back = io.read(path)
    for name, var in ds.variables.items():
        np.testing.assert_array_equal(back[name].values, var.values, err_msg=name)
        assert back[name].attrs == var.attrs, name
        assert back[name].dims == var.dims, name
    # label dimensions are dimension coordinates again: selection by name works
    assert float(back.gain_db.sel(row="torque")) == 0.0
    assert back.matrix.sel(order=3.0).values.tolist() == ds.matrix.sel(order=3.0).values.tolist()
    assert back.attrs["note"] == "kept" and json.loads(back.attrs["flags"]) == [1, 2]


def test_time_is_plain_seconds_on_disk(tmp_path):
    ds = _dataset()
    ds.time.attrs["axis"] = "T"  # a producer's calendar hint is not stored
    path = io.write(ds, tmp_path / "a.nc", stage="unit")
    with netCDF4.Dataset(path) as nc:
        time = nc["time"]
        assert time.units == "s" and time.dtype == np.float64
        assert time.dimensions == (io.TIME_DIM,)
        assert not {"standard_name", "axis", "calendar", "_FillValue"} & set(time.ncattrs())
        assert "time" in nc["torque"].coordinates.split()
    # plain xarray, CF decoding on: numbers in seconds from 0, not dates
    with xr.open_dataset(path) as plain:
        assert plain.time.dtype == np.float64
        np.testing.assert_array_equal(plain.time.values, ds.time.values)
        np.testing.assert_array_equal(plain.torque.values, ds.torque.values)
    back = io.read(path)
    assert back.time.attrs == {"units": "s", "long_name": "time from record start"}
    assert back.torque.dims == ("time",) and "time" in back.indexes
    np.testing.assert_array_equal(back.time.values, ds.time.values)


def test_refuses_a_variable_named_like_the_time_dimension_on_disk(tmp_path):
    ds = _dataset()
    ds[io.TIME_DIM] = ("row", [1.0, 2.0, 3.0], {"units": "1", "long_name": "clash"})
    with pytest.raises(ValueError, match=io.TIME_DIM):
        io.write(ds, tmp_path / "a.nc", stage="unit")


def test_units_and_labels_on_disk_are_cf(tmp_path):
    path = io.write(_dataset(), tmp_path / "a.nc", stage="unit")
    with netCDF4.Dataset(path) as nc:
        assert nc["rpm"].units == "revolution/min"
        assert nc["gain_db"].units == "1" and "decibels" in nc["gain_db"].comment
        assert nc["matrix"].units == "1" and "different units" in nc["matrix"].comment
        assert nc["torque"].comment == "a producer note"
        # string and unsorted dimension coordinates become auxiliary label variables
        assert "row" not in nc.variables and "order" not in nc.variables
        assert list(nc["row_label"][:]) == ["speed", "torque", "angle"]
        assert "row_label" in nc["matrix"].coordinates.split()
        assert "order_label" in nc["matrix"].coordinates.split()


def test_caller_dataset_is_not_modified(tmp_path):
    ds = _dataset()
    before = ds.copy(deep=True)
    io.write(ds, tmp_path / "a.nc", stage="unit", wildcards={"w": 1})
    xr.testing.assert_identical(ds, before)
    for name in ds.variables:
        assert ds[name].attrs == before[name].attrs


@pytest.mark.parametrize("where, attr", [("data", "units"), ("data", "long_name"),
                                         ("coord", "units"), ("coord", "long_name")])
def test_refuses_missing_units_or_long_name(tmp_path, where, attr):
    ds = _dataset()
    name = "torque" if where == "data" else "row_units"
    del ds[name].attrs[attr]
    with pytest.raises(ValueError, match=rf"{name} \({attr}\)"):
        io.write(ds, tmp_path / "a.nc", stage="unit")
    assert list(tmp_path.iterdir()) == []


def test_refuses_time_not_in_seconds(tmp_path):
    ds = _dataset()
    ds.time.attrs["units"] = "ms"
    with pytest.raises(ValueError, match="time.*seconds"):
        io.write(ds, tmp_path / "a.nc", stage="unit")


def test_refuses_label_name_clash(tmp_path):
    ds = _dataset()
    ds["row_label"] = ("row", [1.0, 2.0, 3.0], {"units": "1", "long_name": "clash"})
    with pytest.raises(ValueError, match="row_label"):
        io.write(ds, tmp_path / "a.nc", stage="unit")


def _unencodable() -> xr.Dataset:
    ds = _dataset()
    # netCDF cannot store an object array of mixed types: to_netcdf fails mid-write
    ds["bad"] = ("row", np.array([1, "a", None], dtype=object),
                 {"units": "1", "long_name": "bad"})
    return ds


def test_failed_write_leaves_nothing(tmp_path):
    with pytest.raises(ValueError):
        io.write(_unencodable(), tmp_path / "out" / "a.nc", stage="unit")
    assert list((tmp_path / "out").iterdir()) == []


def test_failed_write_keeps_existing_target(tmp_path):
    path = io.write(_dataset(), tmp_path / "a.nc", stage="first")
    blob = path.read_bytes()
    with pytest.raises(ValueError):
        io.write(_unencodable(), path, stage="second")
    assert path.read_bytes() == blob
    assert [p.name for p in tmp_path.iterdir()] == ["a.nc"]
    assert io.read(path).attrs["stage"] == "first"


def test_file_mode_follows_umask(tmp_path):
    old = os.umask(0o027)
    try:
        path = io.write(_dataset(), tmp_path / "a.nc", stage="unit")
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == 0o640


def test_provenance(tmp_path):
    config = {"b": [1, 2.5], "a": {"z": "x", "y": np.float64(0.25)}, "n": np.int64(3)}
    path = io.write(_dataset(), tmp_path / "a.nc", stage="model", config=config,
                    wildcards={"test": "speed_up", "profile": "square"}, title="A title")
    attrs = io.read(path).attrs
    plain = {"b": [1, 2.5], "a": {"z": "x", "y": 0.25}, "n": 3}
    expected = hashlib.sha256(
        json.dumps(plain, sort_keys=True, separators=(",", ":")).encode()).hexdigest()
    assert attrs["config_sha256"] == expected == io.config_sha256(config)
    assert attrs["gbpipe_version"] == gbpipe.__version__
    assert attrs["stage"] == "model"
    assert attrs["wildcard_test"] == "speed_up" and attrs["wildcard_profile"] == "square"
    assert attrs["Conventions"] == "CF-1.11" and attrs["title"] == "A title"
    # history keeps what came before and appends this stage, with no clock time: nothing
    # in the file says when it was written (the same config gives the same bytes)
    lines = attrs["history"].splitlines()
    assert lines[0] == "2020-01-01: made by hand"
    assert lines[-1] == f"gbpipe {gbpipe.__version__} model"
    today = dt.datetime.now(dt.UTC).date().isoformat()
    assert not [k for k, v in attrs.items() if today in str(v)]
    again = io.write(_dataset(), tmp_path / "b.nc", stage="model", config=config,
                     wildcards={"test": "speed_up", "profile": "square"}, title="A title")
    assert again.read_bytes() == path.read_bytes()


def test_config_hash_distinguishes_slices():
    assert io.config_sha256({"a": 1, "b": 2}) == io.config_sha256({"b": 2, "a": 1})
    assert io.config_sha256({"a": 1}) != io.config_sha256({"a": 1.5})
    assert io.config_sha256(None) == hashlib.sha256(b"null").hexdigest()


def test_read_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="run the stage"):
        io.read(tmp_path / "missing.nc")


@pytest.mark.parametrize("units, expected", [
    ("rev/min", "revolution/min"), ("deg/s", "degree/s"), ("Nm", "N m"), ("N m", "N m"),
    ("(rev/min)^2/Hz", "(revolution/min)^2/Hz"), ("rad s-1", "rad s-1"), ("dB", "1"),
    ("mixed (see units)", "1"), ("degree", "degree"), ("1", "1"),
])
def test_cf_units_are_udunits(units, expected):
    got, note = io.cf_units(units)
    assert got == expected
    assert (note is None) == (expected != "1" or units == "1")
    cf_units.Unit(got)  # parses with UDUNITS-2 (cf_units comes with compliance-checker)
