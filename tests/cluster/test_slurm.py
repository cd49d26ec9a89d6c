"""The CI workflow through the repository's SLURM profile on a real local SLURM.

``snakemake --profile profiles/slurm --configfile config/ci.yaml`` runs in a fresh copy of
the repository against the one-node cluster of conftest.py. Every job of the plan must
appear in SLURM's accounting (sacct, fed by slurmdbd) as a completed SLURM job of its
rule, and the results must equal the local run's (``ci_run``, tests/workflow): every CSV
table byte for byte, every NetCDF variable and coordinate exactly (values, dims, names;
attributes such as the creation time differ by nature).
"""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path

import xarray as xr
from slurm_runs import last_job_id, slurm_jobs, snakemake_on_slurm

from tests.workflow.runs import copy_repo, snakemake_env


def executed_jobs(log: str) -> Counter:
    """Rule -> jobs of the 'Job stats' table Snakemake prints before it runs, but the
    target rule ``all`` (it runs nothing, so never becomes a SLURM job)."""
    table = log.split("Job stats:", 1)[1].split("\n\n", 1)[0]
    return Counter({m[1]: int(m[2]) for m in re.finditer(r"^(\w+)\s+(\d+)\s*$", table, re.M)
                    if m[1] not in ("total", "all")})


def _relative(root: Path, pattern: str) -> list[Path]:
    return sorted(p.relative_to(root) for p in (root / "results").glob(pattern))


def test_ci_workflow_on_slurm_runs_every_job_as_slurm_job_and_matches_local_run(
        slurm, ci_run, tmp_path_factory):
    work = copy_repo(tmp_path_factory.mktemp("slurm_run"))
    before = last_job_id(slurm)
    proc = snakemake_on_slurm(slurm, work, snakemake_env(work), "--configfile",
                              "config/ci.yaml")

    jobs = slurm_jobs(slurm, after=before).values()
    assert Counter(j["rule"] for j in jobs) == executed_jobs(proc.stdout + proc.stderr)
    assert {s for j in jobs for s in j["states"]} == {"COMPLETED"}
    # the rules' own memory (e.g. sweep: 4000 MB) reached SLURM, not only the default
    assert {j["mem_mb"] for j in jobs if j["rule"] == "sweep"} == {4000}

    tables = _relative(ci_run, "tables/*.csv")
    assert tables and tables == _relative(work, "tables/*.csv")
    differ = [str(t) for t in tables
              if (ci_run / t).read_bytes() != (work / t).read_bytes()]
    assert differ == []

    netcdf = _relative(ci_run, "**/*.nc")
    assert len(netcdf) >= 20 and netcdf == _relative(work, "**/*.nc")
    for path in netcdf:
        with xr.open_dataset(ci_run / path) as local, xr.open_dataset(work / path) as remote:
            xr.testing.assert_equal(remote, local)
