"""Many gearboxes in one call: config/examples/study.yaml's four runs, one results folder
each, run locally by one ``snakemake -j2`` (the ``study_run`` fixture: the kinematics and
model stages of every run).

Each run's outputs are checked against an independent computation: the mass and
stiffness matrices of the same overlay assembled by hand (tests/model/hand_models.py),
and for the run without an overlay, the plain CI run (``ci_run``) byte for byte.
"""

from __future__ import annotations

import csv
import math
import re
from collections import Counter
from fractions import Fraction

import numpy as np
import pytest
import xarray as xr

from gbpipe import io
from gbpipe.config import load
from tests.conftest import CI_CONFIG, CONFIG, EXAMPLE, STUDY_RUNS
from tests.model import hand_models

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
    # the expectation is built without gbpipe.model: M and K assembled by hand from the
    # run's own config (tests/model/hand_models.py), and numpy's eigenvalues of the
    # stored state matrix
    work, _ = study_run
    cfg = load(CONFIG, CI_CONFIG, *OVERLAYS[name])
    folder = work / "results" / name / "model"
    gearbox, bench = io.read(folder / "gearbox.nc"), io.read(folder / "bench.nc")
    np.testing.assert_allclose(
        gearbox.undamped_frequency.values,
        hand_models.frequencies(*hand_models.gearbox_matrices(cfg["gearbox"])), rtol=1e-6)
    np.testing.assert_allclose(
        bench.plant_undamped_frequency.values,
        hand_models.frequencies(*hand_models.bench_matrices(cfg)), rtol=1e-6)
    # the damped modes stored are those of the stored A (one per conjugate pair)
    lam = np.linalg.eigvals(gearbox.A.values)
    lam = lam[(lam.imag > 0) & (np.abs(lam) > 1e-6 * np.abs(lam).max())]
    np.testing.assert_allclose(np.sort(gearbox.mode_frequency.values),
                               np.sort(np.abs(lam) / (2 * np.pi)), rtol=1e-8)
    np.testing.assert_allclose(
        np.sort(gearbox.mode_damping.values),
        np.sort(-lam.real / np.abs(lam)), rtol=1e-6, atol=1e-12)


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
    for name in ("nominal", "planetary_parallel"):
        with open(work / "results" / name / "tables" / "table2.csv", newline="") as fh:
            orders = {r["name"]: Fraction(r["order_exact"]) for r in csv.DictReader(fh)}
        assert orders == _orders_by_hand(load(CONFIG, CI_CONFIG, *OVERLAYS[name])), name


def _orders_by_hand(cfg) -> dict[str, Fraction]:
    """HSS orders of the LSS and of each gear mesh from the tooth counts: a planetary stage
    (ring fixed) multiplies by 1 + Zr/Zs and meshes at Zr times its carrier's speed, a
    parallel stage by Zw/Zp and meshes at Zw times its wheel's speed; the HSS is order 1."""
    stages = cfg["gearbox"]["stages"]
    ratios = [Fraction(st["ring"], st["sun"]) + 1 if st["type"] == "planetary"
              else Fraction(st["wheel"], st["pinion"]) for st in stages]
    out = {"hss": Fraction(1), "lss": 1 / math.prod(ratios)}
    speed = out["lss"]                              # input member of stage 1
    for i, (st, ratio) in enumerate(zip(stages, ratios, strict=True), start=1):
        out[f"mesh{i}"] = speed * st["ring" if st["type"] == "planetary" else "wheel"]
        speed *= ratio
        if i < len(stages):
            out[f"is{i}"] = speed
    return out


def test_the_run_without_overlay_equals_the_single_run(study_run, ci_run):
    work, _ = study_run
    single, nominal = ci_run / "results", work / "results" / "nominal"
    assert (single / "tables" / "table2.csv").read_bytes() == \
           (nominal / "tables" / "table2.csv").read_bytes()
    for part in ("gearbox", "bench", "truth"):
        with xr.open_dataset(single / "model" / f"{part}.nc") as a, \
             xr.open_dataset(nominal / "model" / f"{part}.nc") as b:
            xr.testing.assert_equal(a, b)
