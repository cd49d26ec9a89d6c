"""Failed SLURM jobs: retried with more memory, and never leaving a partial output.

tests/cluster/retry/Snakefile has two rules whose jobs write part of their output, then
fail on their first attempt (1000 MB): ``oom`` touches 1200 MiB and is killed by SLURM's
memory cgroup (state OUT_OF_MEMORY); ``cancelled`` waits and is cancelled by a watcher
thread here with ``scancel`` (state CANCELLED). Both take their memory from the
workflow's own resource functions (``Declared`` of ``workflow/lib/jobresources.py`` over
``retry/resources.yaml``: 1000 MB times the attempt) and run through the repository's
SLURM profile. Without retries, the run fails and neither output exists (Snakemake removed
the partial files); with ``retries: 1``, each rule's second SLURM job asks for 2000 MB and
completes, and each output holds that attempt's content only.
"""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

from slurm_local import LocalSlurm
from slurm_runs import last_job_id, slurm_jobs, snakemake_on_slurm

SNAKEFILE = Path(__file__).parent / "retry" / "Snakefile"
#: Seconds the watcher waits for the first ``cancelled`` job to run: only a hang reaches
#: it, however loaded the machine (the watcher acts on the job's state, not on time).
WATCH_TIMEOUT = 1800.0


def _scancel_first_attempt(cluster: LocalSlurm, work: Path, stop: threading.Event,
                           cancelled: list[int]) -> None:
    """Cancel the first running ``cancelled`` job once its partial output is written."""
    partial = work / "cancelled.txt"
    deadline = time.monotonic() + WATCH_TIMEOUT
    while not stop.is_set() and time.monotonic() < deadline:
        queue = cluster.run("squeue", "-h", "-t", "RUNNING", "-o", "%i|%k", check=False)
        for jobid, comment in (x.split("|", 1) for x in queue.stdout.split()):
            if comment == "rule_cancelled" and partial.exists() and partial.read_text():
                cluster.run("scancel", jobid)
                cancelled.append(int(jobid))
                return
        time.sleep(0.3)


def _run(cluster: LocalSlurm, work: Path, *args: str):
    """Run the retry workflow in ``work`` on SLURM, cancelling the first ``cancelled``
    job; return Snakemake's process, the cancelled job ids and rule -> [(states, MB)]."""
    work.mkdir()
    before = last_job_id(cluster)
    stop, cancelled = threading.Event(), []
    watcher = threading.Thread(target=_scancel_first_attempt,
                               args=(cluster, work, stop, cancelled))
    watcher.start()
    try:
        proc = snakemake_on_slurm(cluster, work, dict(os.environ), "--snakefile",
                                  str(SNAKEFILE), "--keep-going", *args, check=False)
    finally:
        stop.set()
        watcher.join()
    attempts: dict[str, list] = {}
    for _, job in sorted(slurm_jobs(cluster, after=before).items()):
        attempts.setdefault(job["rule"], []).append((set(job["states"]), job["mem_mb"]))
    return proc, cancelled, attempts


def test_failed_slurm_jobs_leave_no_partial_output(slurm, tmp_path):
    work = tmp_path / "no_retries"
    proc, cancelled, attempts = _run(slurm, work, "--config", "retries=0")
    assert proc.returncode != 0
    assert len(cancelled) == 1
    (oom_states, oom_mb), = attempts["oom"]
    (cancel_states, cancel_mb), = attempts["cancelled"]
    assert "OUT_OF_MEMORY" in oom_states and oom_mb == 1000
    assert "CANCELLED" in cancel_states and cancel_mb == 1000
    # both jobs had written "started ..." before they died
    assert not (work / "oom.txt").exists()
    assert not (work / "cancelled.txt").exists()


def test_oom_and_scancel_are_retried_with_twice_the_memory(slurm, tmp_path):
    work = tmp_path / "retries"
    proc, cancelled, attempts = _run(slurm, work)
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert len(cancelled) == 1
    (first, first_mb), (second, second_mb) = attempts["oom"]
    assert "OUT_OF_MEMORY" in first and (first_mb, second_mb) == (1000, 2000)
    assert second == {"COMPLETED"}
    (first, first_mb), (second, second_mb) = attempts["cancelled"]
    assert "CANCELLED" in first and (first_mb, second_mb) == (1000, 2000)
    assert second == {"COMPLETED"}
    for name in ("oom.txt", "cancelled.txt"):
        assert (work / name).read_text() == "started mem_mb=2000\ncomplete\n"
