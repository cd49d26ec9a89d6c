"""Many gearboxes in one call: config/examples/study.yaml's four runs, one results folder
each, run locally by one ``snakemake -j2`` (the ``study_run`` fixture: the kinematics and
model stages of every run).

Each run's outputs are checked against an independent computation: the library's model
of the same overlay loaded on its own (``gbpipe.config.load``), and for the run without
an overlay, the plain CI run (``ci_run``) byte for byte.
"""

from __future__ import annotations

import re
from collections import Counter

import numpy as np
import pytest
import xarray as xr

from gbpipe import io, model
from gbpipe.config import load
from tests.conftest import CI_CONFIG, CONFIG, EXAMPLE, STUDY_RUNS

OVERLAYS = {
    "nominal": (),
    "planetary_parallel": (EXAMPLE,),
    "soft_coupling": ({"bench": {"coupling": {"stiffness": 3.0e6}}},),
    "stiff_housing": ({"gearbox": {"housing": {"stiffness": 8.0e8}}},),
}


def test_one_call_runs_every_run_in_its_own_folder(study_run):
    work, log = study_run
    assert sorted(p.name for p in (work / "results").iterdir()) == sorted(STUDY_RUNS)
    table = log.split("Job stats:", 1)[1].split("\n\n", 1)[0]
    jobs = Counter({m[1]: int(m[2]) for m in re.finditer(r"^(\w+)\s+(\d+)\s*$", table,
                                                         re.M) if m[1] != "total"})
    assert jobs == Counter({f"{n}_{r}": 1 for n in STUDY_RUNS
                            for r in ("kinematics", "model", "figures_model")})


@pytest.mark.parametrize("name", STUDY_RUNS)
def test_each_run_holds_the_model_of_its_own_config(study_run, name):
    work, _ = study_run
    cfg = load(CONFIG, CI_CONFIG, *OVERLAYS[name])
    truth_cfg = {k: cfg["identify"][k] for k in ("pairings", "frf", "zeta_max")}
    expect = model.model_datasets(cfg, truth_cfg)
    for part in ("gearbox", "bench", "truth"):
        got = io.read(work / "results" / name / "model" / f"{part}.nc")
        for var in expect[part].data_vars:
            np.testing.assert_allclose(got[var].values, expect[part][var].values,
                                       rtol=1e-10, atol=0, err_msg=f"{name} {part} {var}")


def test_the_runs_differ_as_their_physics_says(study_run):
    """A softer HSS coupling lowers the bench's highest-participation coupling mode and a
    stiffer housing raises the housing mode; another gearbox has its own Table 2."""
    work, _ = study_run

    def plant_modes(name):
        with xr.open_dataset(work / "results" / name / "model" / "bench.nc") as ds:
            return np.sort(ds.plant_undamped_frequency.values)

    nominal, soft, stiff = (plant_modes(n) for n in
                            ("nominal", "soft_coupling", "stiff_housing"))
    assert np.all(soft <= nominal * (1 + 1e-9)) and np.any(soft < 0.95 * nominal)
    assert np.all(stiff >= nominal * (1 - 1e-9)) and np.any(stiff > 1.03 * nominal)
    tables = {n: (work / "results" / n / "tables" / "table2.csv").read_text()
              for n in ("nominal", "planetary_parallel")}
    assert tables["nominal"] != tables["planetary_parallel"]


def test_the_run_without_overlay_equals_the_single_run(study_run, ci_run):
    work, _ = study_run
    single, nominal = ci_run / "results", work / "results" / "nominal"
    assert (single / "tables" / "table2.csv").read_bytes() == \
           (nominal / "tables" / "table2.csv").read_bytes()
    for part in ("gearbox", "bench", "truth"):
        with xr.open_dataset(single / "model" / f"{part}.nc") as a, \
             xr.open_dataset(nominal / "model" / f"{part}.nc") as b:
            xr.testing.assert_equal(a, b)
