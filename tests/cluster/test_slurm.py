"""The workflow through the repository's SLURM profile on a real local SLURM.

``snakemake --profile profiles/slurm --configfile config/ci.yaml`` runs in a fresh copy of
the repository against the one-node cluster of conftest.py. Every job of the plan must
appear in SLURM's accounting (sacct, fed by slurmdbd) as a completed SLURM job of its
rule, on its first attempt, having asked for its rule's declared memory
(workflow/resources.yaml) and used less; and the results must equal the local run's
(``ci_run``): every CSV table byte for byte, every NetCDF variable and coordinate exactly
(values, dims, names; attributes such as the creation time differ by nature).

The study of config/examples/study.yaml (four gearboxes and benches, one results folder
each) runs the same way and must equal its local run (``study_run``). Both SLURM runs (and
those of test_slurm_retries.py) are started together in the background when the session
is collected (conftest.py); their jobs are told apart by their working directory.
"""

from __future__ import annotations

import os
import re
import sys
from collections import Counter
from pathlib import Path

import pytest
import xarray as xr
from slurm_local import _stale_test_link
from slurm_runs import MEMORY, slurm_jobs

from tests.conftest import ROOT

sys.path.insert(0, str(ROOT / "workflow" / "lib"))
import jobresources  # noqa: E402  (the workflow's own helpers)

DECLARED = jobresources.Declared()


def executed_jobs(log: str) -> Counter:
    """Rule -> jobs of the 'Job stats' table Snakemake prints before it runs, but the
    target rule ``all`` (it runs nothing, so never becomes a SLURM job)."""
    table = log.split("Job stats:", 1)[1].split("\n\n", 1)[0]
    return Counter({m[1]: int(m[2]) for m in re.finditer(r"^(\w+)\s+(\d+)\s*$", table, re.M)
                    if m[1] not in ("total", "all")})


def _relative(root: Path, pattern: str) -> list[Path]:
    return sorted(p.relative_to(root) for p in (root / "results").glob(pattern))


def _assert_jobs_as_planned_and_declared(jobs: list[dict], log: str, rule_of) -> None:
    """One completed SLURM job per planned job (so none was retried), each asking for its
    rule's declared memory and time, and using less memory than it asked for."""
    assert Counter(j["rule"] for j in jobs) == executed_jobs(log)
    assert {s for j in jobs for s in j["states"]} == {"COMPLETED"}
    asked = {(j["rule"], j["mem_mb"]) for j in jobs}
    assert asked == {(j["rule"], DECLARED.mem_mb(rule_of(j["rule"]))) for j in jobs}
    over = [(j["rule"], round(j["rss_mb"]), j["mem_mb"]) for j in jobs
            if not 0 < j["rss_mb"] <= j["mem_mb"]]
    assert over == []
    for j in jobs:
        rule = rule_of(j["rule"])
        peak = max(j["rss_mb"], MEMORY.get(rule, (0.0, 0))[0])
        MEMORY[rule] = (peak, j["mem_mb"])


def _assert_same_results(local: Path, remote: Path, tables: str, min_netcdf: int) -> None:
    names = _relative(local, tables)
    assert names and names == _relative(remote, tables)
    differ = [str(t) for t in names if (local / t).read_bytes() != (remote / t).read_bytes()]
    assert differ == []
    netcdf = _relative(local, "**/*.nc")
    assert len(netcdf) >= min_netcdf and netcdf == _relative(remote, "**/*.nc")
    for path in netcdf:
        with xr.open_dataset(local / path) as a, xr.open_dataset(remote / path) as b:
            xr.testing.assert_equal(b, a)


@pytest.mark.slurm_runs("ci")
def test_ci_workflow_on_slurm_runs_every_job_as_slurm_job_and_matches_local_run(
        slurm_runs, slurm, ci_run):
    run = slurm_runs["ci"]
    log = run.result()
    jobs = list(slurm_jobs(slurm, run.work).values())
    _assert_jobs_as_planned_and_declared(jobs, log, lambda r: r)
    _assert_same_results(ci_run, run.work, "tables/*.csv", min_netcdf=20)


@pytest.mark.slurm_runs("study")
def test_a_study_of_four_gearboxes_on_slurm_matches_its_local_run(
        slurm_runs, slurm, study_run):
    local, _ = study_run
    run = slurm_runs["study"]
    log = run.result()
    jobs = list(slurm_jobs(slurm, run.work).values())
    runs = sorted(p.name for p in (local / "results").iterdir())
    assert len(runs) == 4

    def rule_of(name: str) -> str:   # <run>_<rule> -> <rule>
        run = next(r for r in runs if name.startswith(f"{r}_"))
        return name.removeprefix(f"{run}_")

    _assert_jobs_as_planned_and_declared(jobs, log, rule_of)
    assert {j["rule"] for j in jobs} == {f"{r}_{x}" for r in runs
                                         for x in ("kinematics", "model", "figures_model")}
    _assert_same_results(local, run.work, "*/tables/*.csv", min_netcdf=16)


def test_only_a_dead_test_clusters_link_counts_as_stale(tmp_path):
    """The test cluster replaces /etc/slurm/slurm.conf only when it is its own leftover:
    a link into a pruned pytest folder (a killed session) is stale; a dangling link
    elsewhere, a regular file, or a link to a live cluster's folder is not."""
    conf = tmp_path / "slurm.conf"
    conf.symlink_to(tmp_path / "pytest-of-root" / "pytest-7" / "slurm0" / "slurm.conf")
    assert _stale_test_link(conf)
    conf.unlink()
    conf.symlink_to(Path("/nonexistent-site/etc/slurm/slurm.conf"))   # not a test folder
    assert not _stale_test_link(conf)
    conf.unlink()
    conf.write_text("ClusterName=site\n")
    assert not _stale_test_link(conf)
    conf.unlink()
    live = tmp_path / "live"
    live.mkdir()
    (live / "pids.json").write_text(f"[[{os.getpid()}]]")
    conf.symlink_to(live / "slurm.conf")
    assert not _stale_test_link(conf)
