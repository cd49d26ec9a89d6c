"""gbpipe.io.block_writer: a dataset filled block by block (in a random order, blocks of
random lengths) gives the file gbpipe.io.write gives for the whole dataset, read with
plain xarray and netCDF4; a failure or a half-filled variable leaves no file."""

from __future__ import annotations

import netCDF4
import numpy as np
import pytest
import xarray as xr

from gbpipe import io
from gbpipe.io.atomic import TEMP_GLOB


def _dataset(n: int, seed: int) -> xr.Dataset:
    """Every kind of variable a stage writes: float and int8 series on time, a 2-D series
    on time and labels, mixed units, string coordinates, a zero-length dimension, values
    off time."""
    rng = np.random.default_rng(seed)
    targets = ["torque_b", "torque_a", "speed_c"]
    return xr.Dataset(
        {"estimate": (("time", "target"), rng.standard_normal((n, 3)) * [1e3, 10.0, 0.1],
                      {"units": "mixed (see target_units)", "long_name": "estimate"}),
         "flag": ("time", (rng.random(n) > 0.3).astype(np.int8),
                  {"units": "1", "long_name": "a flag"}),
         "speed": ("time", np.cumsum(rng.standard_normal(n)),
                   {"units": "rev/min", "long_name": "speed", "comment": "a comment"}),
         "sd": ("target", rng.random(3), {"units": "mixed (see target_units)",
                                          "long_name": "sd"}),
         "statistic": ("target", rng.random(3), {"units": "percent", "long_name": "late"}),
         "empty": ("load", np.zeros(0), {"units": "N m", "long_name": "no load"}),
         "scalar": ((), 2.5, {"units": "N m", "long_name": "a scalar"})},
        coords={"time": ("time", np.arange(n) / 500.0, {"units": "s", "long_name": "time"}),
                "target": ("target", targets, {"units": "1", "long_name": "target"}),
                "target_units": ("target", ["N m", "N m", "rad/s"],
                                 {"units": "1", "long_name": "unit"}),
                "load": ("load", np.array([], dtype=str), {"units": "1", "long_name": "load"})},
        attrs={"model": "configured", "noise_scale": 1.25})


def _spans(n: int, rng: np.random.Generator) -> list[tuple[int, int]]:
    cuts = np.unique(np.concatenate([[0, n], rng.integers(1, n, 9)]))
    spans = list(zip(cuts[:-1].tolist(), cuts[1:].tolist(), strict=True))
    rng.shuffle(spans)
    return spans


def _provenance() -> dict:
    return {"stage": "virtual", "config": {"a": 1}, "wildcards": {"record": "r"},
            "title": "a title"}


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_blocks_give_the_file_of_the_whole_dataset(tmp_path, seed):
    n = 1500 + 37 * seed
    ds = _dataset(n, seed)
    whole = io.write(ds, tmp_path / "whole.nc", **_provenance())
    template = ds.isel(time=slice(0, 2)).copy()
    template["statistic"] = template.statistic * 0.0      # a placeholder, set at the end
    rng = np.random.default_rng(seed + 10)
    with io.block_writer(template, n, tmp_path / "blocks.nc", late=["statistic"],
                         **_provenance()) as f:
        for a, b in _spans(n, rng):
            for name in ("time", "estimate", "flag", "speed"):
                values = ds[name].values
                f.write(name, a, values[a:b])
        # what was written reads back
        assert np.array_equal(f.read("speed", 5, 9), ds.speed.values[5:9])
        f.set("statistic", ds.statistic.values)
    a = xr.open_dataset(whole, decode_times=False)
    b = xr.open_dataset(tmp_path / "blocks.nc", decode_times=False)
    assert dict(a.sizes) == dict(b.sizes)
    assert a.encoding["unlimited_dims"] == b.encoding["unlimited_dims"]
    assert set(a.variables) == set(b.variables)
    for name, var in a.variables.items():
        assert var.dims == b[name].dims, name
        assert var.dtype == b[name].dtype, name
        assert np.array_equal(var.values, b[name].values), name
        assert var.attrs == b[name].attrs, name
        for key in ("zlib", "shuffle", "complevel", "_FillValue", "dtype"):
            assert str(var.encoding.get(key)) == str(b[name].encoding.get(key)), (name, key)
    assert a.attrs == b.attrs
    # and gbpipe's reader undoes the encoding of both alike
    ra, rb = io.read(whole), io.read(tmp_path / "blocks.nc")
    assert ra.estimate.attrs == rb.estimate.attrs
    assert list(rb.target.values) == ["torque_b", "torque_a", "speed_c"]
    with netCDF4.Dataset(tmp_path / "blocks.nc") as nc:
        assert nc["estimate"].chunking() == [min(n, io.blocks.CHUNK), 3]


def test_failure_leaves_no_file_and_the_old_one_untouched(tmp_path):
    n = 300
    ds = _dataset(n, 4)
    target = tmp_path / "out.nc"
    target.write_text("the old output")
    with pytest.raises(RuntimeError), \
            io.block_writer(ds.isel(time=slice(0, 2)), n, target, stage="virtual") as f:
        f.write("speed", 0, ds.speed.values[:100])
        raise RuntimeError("the stage failed")
    assert target.read_text() == "the old output"
    assert list(tmp_path.glob(TEMP_GLOB)) == []


def test_half_filled_or_unset_is_refused(tmp_path):
    n = 300
    ds = _dataset(n, 5)
    target = tmp_path / "out.nc"
    with pytest.raises(ValueError, match="speed: sample 120"), \
            io.block_writer(ds.isel(time=slice(0, 2)), n, target, stage="virtual") as f:
        for name in ("time", "estimate", "flag"):
            f.write(name, 0, ds[name].values)
        f.write("speed", 0, ds.speed.values[:120])
        f.write("speed", 121, ds.speed.values[121:])
    assert not target.exists()
    with pytest.raises(ValueError, match="statistic: never set"), \
            io.block_writer(ds.isel(time=slice(0, 2)), n, target, stage="virtual",
                            late=["statistic"]) as f:
        for name in ("time", "estimate", "flag", "speed"):
            f.write(name, 0, ds[name].values)
    assert not target.exists()
    assert list(tmp_path.glob(TEMP_GLOB)) == []
    with pytest.raises(ValueError, match="outside"), \
            io.block_writer(ds.isel(time=slice(0, 2)), n, target, stage="virtual") as f:
        f.write("speed", n - 5, np.zeros(10))
