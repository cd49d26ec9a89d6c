"""The same config gives the same files: stages run again on the inputs of a CI run
write NetCDF files equal to the first run's byte for byte (no clock time in them, nor in
any variable, coordinate or attribute), and the same captions. Wall time and memory belong
to the job logs and benchmarks, never to results."""

from __future__ import annotations

import shutil

import numpy as np
import xarray as xr

from tests.workflow.runs import snakemake

#: The stages run again (their inputs kept), one group after the other: the harmonic-removal
#: comparison, which timed its methods into its results, with its caption and the
#: kinematics; then the model (whose files the removal files name with their SHA-256).
AGAIN = (("results/kinematics/frequencies.nc", "results/removal/*.nc",
          "results/report/fig_removal_tradeoff.rst"),
         ("results/model/gearbox.nc", "results/model/bench.nc", "results/model/truth.nc"))


def _same(a: xr.Dataset, b: xr.Dataset, name: str) -> None:
    # numpy's equality: NaN equals NaN (a _FillValue of NaN is the same in both files)
    np.testing.assert_equal(b.attrs, a.attrs, name)
    assert list(a.variables) == list(b.variables), name
    for var in a.variables:
        np.testing.assert_equal(b[var].attrs, a[var].attrs, f"{name} {var}")
        assert a[var].dims == b[var].dims, (name, var)
        np.testing.assert_array_equal(a[var].values, b[var].values, err_msg=f"{name} {var}")


def test_the_same_config_gives_the_same_files(ci_run, tmp_path):
    again = shutil.copytree(ci_run, tmp_path / "again", symlinks=True)
    checked = 0
    for group in AGAIN:
        files = sorted({p.relative_to(ci_run) for pattern in group
                        for p in ci_run.glob(pattern)})
        for f in files:
            (again / f).unlink()
        snakemake(again, "--", *map(str, files))
        for f in files:
            if f.suffix == ".rst":
                assert (again / f).read_text() == (ci_run / f).read_text(), f
                continue
            # the file as stored (no decoding): what a reader of either run gets
            with (xr.open_dataset(ci_run / f, decode_cf=False) as a,
                  xr.open_dataset(again / f, decode_cf=False) as b):
                _same(a.load(), b.load(), str(f))
            assert (again / f).read_bytes() == (ci_run / f).read_bytes(), f
            checked += 1
    assert checked >= 8   # kinematics, five removal methods, three model files
