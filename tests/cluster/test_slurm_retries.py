"""Failed SLURM jobs: retried with more memory, and never leaving a partial output.

tests/cluster/retry/Snakefile has two rules whose jobs write part of their output, then
fail on their first attempt (1000 MB): ``oom`` touches 1200 MiB and is killed by SLURM's
memory cgroup (state OUT_OF_MEMORY); ``cancelled`` waits and is cancelled by a watcher
thread here with ``scancel`` (state CANCELLED). Both take their memory from the
workflow's own resource functions (``Declared`` of ``workflow/lib/jobresources.py`` over
``retry/resources.yaml``: 1000 MB times the attempt) and run through the repository's
SLURM profile. Without retries, the run fails and neither output exists (Snakemake removed
the partial files); with ``retries: 1``, each rule's second SLURM job asks for 2000 MB and
completes, and each output holds that attempt's content only. Both runs are started
together with the other SLURM runs (in the background, conftest.py; `RetryRun` of
slurm_runs.py holds the watcher); their jobs are told apart by their working directory.
"""

from __future__ import annotations

import pytest
from slurm_local import LocalSlurm
from slurm_runs import RetryRun, slurm_jobs


def _attempts(cluster: LocalSlurm, run: RetryRun) -> dict[str, list]:
    """Rule -> [(states, MB asked)] of each SLURM job of the run, in submission order."""
    attempts: dict[str, list] = {}
    for _, job in sorted(slurm_jobs(cluster, run.work).items()):
        attempts.setdefault(job["rule"], []).append((set(job["states"]), job["mem_mb"]))
    return attempts


@pytest.mark.slurm_runs("no_retries")
def test_failed_slurm_jobs_leave_no_partial_output(slurm_runs, slurm):
    run = slurm_runs["no_retries"]
    code, _ = run.wait()
    work, cancelled, attempts = run.work, run.cancelled, _attempts(slurm, run)
    assert code != 0
    assert len(cancelled) == 1
    (oom_states, oom_mb), = attempts["oom"]
    (cancel_states, cancel_mb), = attempts["cancelled"]
    assert "OUT_OF_MEMORY" in oom_states and oom_mb == 1000
    assert "CANCELLED" in cancel_states and cancel_mb == 1000
    # both jobs had written "started ..." before they died
    assert not (work / "oom.txt").exists()
    assert not (work / "cancelled.txt").exists()


@pytest.mark.slurm_runs("retries")
def test_oom_and_scancel_are_retried_with_twice_the_memory(slurm_runs, slurm):
    run = slurm_runs["retries"]
    code, log = run.wait()
    work, cancelled, attempts = run.work, run.cancelled, _attempts(slurm, run)
    assert code == 0, log[-4000:]
    assert len(cancelled) == 1
    (first, first_mb), (second, second_mb) = attempts["oom"]
    assert "OUT_OF_MEMORY" in first and (first_mb, second_mb) == (1000, 2000)
    assert second == {"COMPLETED"}
    (first, first_mb), (second, second_mb) = attempts["cancelled"]
    assert "CANCELLED" in first and (first_mb, second_mb) == (1000, 2000)
    assert second == {"COMPLETED"}
    for name in ("oom.txt", "cancelled.txt"):
        assert (work / name).read_text() == "started mem_mb=2000\ncomplete\n"
