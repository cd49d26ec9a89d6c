"""config/examples/shaftline.yaml's virtual sensors end to end: bench files the test
writes (the example's chain, tests/measured/shaftline_bench.py) -> measured -> virtual ->
the table and the figure; the held-out torque meter against its estimate."""

from __future__ import annotations

import csv

import numpy as np

from gbpipe import io
from gbpipe.lti import fit_percent
from tests.measured.shaftline_bench import write_bench
from tests.workflow.runs import copy_repo, snakemake


def test_shaftline_held_out_torque_meter(tmp_path):
    work = copy_repo(tmp_path)
    truth = write_bench(work / "shaftline", duration=14.0, seed=3)
    snakemake(work, "--configfile", "config/ci.yaml", "config/examples/shaftline.yaml",
              "--nolock", "results/tables/virtual.csv", "results/figures/fig_virtual_run1.png")
    ds = io.read(work / "results" / "virtual" / "run1.nc")
    with open(work / "results" / "tables" / "virtual.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["signal"] for r in rows] == ["torque_input"]
    # the table's fit is the held-out file signal against the estimate (steady part),
    # recomputed here from the bench file's values the test wrote
    steady = ds.steady.values.astype(bool)
    j = list(ds.target.values).index("torque_input")
    measured = truth.signals["torque_input"][steady]
    estimate = ds.estimate.values[steady, j]
    fit = fit_percent(measured - measured.mean(), estimate - estimate.mean())[0]
    assert abs(float(rows[0]["fit_percent"]) - fit) < 0.05   # float32 storage of the record
    assert fit >= 95.0
    assert 0.90 <= float(rows[0]["coverage_95"]) <= 0.99
    # every shaft of the chain is estimated and has load spectra
    assert {f"torque_{s['name']}" for s in truth.cfg["drivetrain"]["shafts"]} <= set(
        ds.signal.values)
    assert np.all(ds["del"].values > 0)
