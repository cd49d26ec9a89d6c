"""Snakemake runs on the local SLURM of tests/cluster, and their jobs as sacct has them.

The runs of the cluster tests share the one-node cluster at the same time (`SlurmRun`
starts one in the background; conftest.py starts them all at once, when the session is
collected): their jobs are told apart by the working directory SLURM accounted for each job
(the executor submits every job with ``-D <the run's directory>``), never by job ids or
the order of submission.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections import defaultdict
from pathlib import Path

from slurm_local import LocalSlurm

from tests.conftest import ROOT
from tests.workflow.runs import snakemake_env

#: The repository's SLURM profile (what a user runs).
PROFILE = ROOT / "profiles" / "slurm"
#: The workflow of the retry tests: two jobs that fail on their first attempt.
RETRY_SNAKEFILE = Path(__file__).parent / "retry" / "Snakefile"
#: Seconds before the executor's first status query (its default, 40 s, suits a big
#: cluster's controller; a one-node test cluster answers at once).
FAST_STATUS = ["--slurm-init-seconds-before-status-checks", "2"]
#: Seconds a run may take: only a hang reaches it, however loaded the machine (the CI
#: config on SLURM takes about two minutes on 2 idle cores).
HANG_S = 3600.0
#: Rule -> (largest peak memory of its SLURM jobs as sacct accounted it, Snakemake
#: included; memory its jobs asked for) [MB]: filled by the tests, printed at the end.
MEMORY: dict[str, tuple[float, int]] = {}


def slurm_jobs(cluster: LocalSlurm, workdir: Path) -> dict[int, dict]:
    """Jobs that ran in ``workdir``, from ``sacct``: id -> rule (from the comment that
    Snakemake's executor sets), the states of the job and of its steps, memory asked [MB],
    and ``rss_mb``: the sum of its steps' peak resident memory [MB] (the batch script's
    Snakemake and the srun step with the rule's script run at once, so the sum bounds the
    job's peak from above).
    """
    out = cluster.run("sacct", "-a", "-n", "-P", "-S", "2000-01-01", "-o",
                      "JobIDRaw,State,ReqMem,MaxRSS,WorkDir,Comment").stdout
    jobs: dict[int, dict] = defaultdict(lambda: {"states": [], "rss_mb": 0.0})
    for line in out.splitlines():
        jobid, state, reqmem, maxrss, cwd, comment = line.split("|", 5)
        main = int(jobid.split(".")[0])
        jobs[main]["states"].append(state.split()[0])  # "CANCELLED by 0" -> CANCELLED
        if maxrss:
            jobs[main]["rss_mb"] += _megabytes(maxrss, "K")
        if "." not in jobid:
            rule = re.match(r"rule_(\w+?)(?:_wildcards_.*)?$", comment)
            jobs[main]["rule"] = rule.group(1) if rule else comment
            jobs[main]["mem_mb"] = round(_megabytes(reqmem))
            jobs[main]["workdir"] = cwd
    return {i: j for i, j in jobs.items()
            if Path(j.get("workdir", "/")).resolve() == workdir.resolve()}


def _megabytes(amount: str, bare: str = "M") -> float:
    # sacct prints e.g. 2000M or 4G (22.05: no trailing n/c), MaxRSS e.g. 123456K or 0
    if amount[-1].isdigit():
        amount += bare
    value, unit = float(amount[:-1]), amount[-1]
    return value * {"K": 1 / 1024, "M": 1, "G": 1024, "T": 1024**2}[unit]


class SlurmRun:
    """``snakemake --profile profiles/slurm ARGS`` in ``work``, started in the background
    (every job a SLURM job); `wait` for its end.

    Snakemake's output goes to ``<work>.log`` beside ``work`` (a file: a pipe nobody reads
    while the run lasts would fill up and stall it).
    """

    def __init__(self, cluster: LocalSlurm, work: Path, env: dict[str, str], *args: str):
        self.work = work
        self.log = work.with_name(f"{work.name}.log")
        with open(self.log, "w") as fh:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "snakemake", "--profile", str(PROFILE), *FAST_STATUS,
                 *args], cwd=work, stdout=fh, stderr=subprocess.STDOUT,
                env=cluster.client_env(env), start_new_session=True)

    def wait(self) -> tuple[int, str]:
        """Exit code and output of the run, once it ended (a hang fails, never blocks)."""
        try:
            self.proc.wait(timeout=HANG_S)
        except subprocess.TimeoutExpired:
            self.stop()
            raise AssertionError(f"snakemake on SLURM in {self.work} still running after "
                                 f"{HANG_S} s (a hang):\n{self.log.read_text()[-6000:]}") from None
        return self.proc.returncode, self.log.read_text()

    def result(self) -> str:
        """Output of a run that must succeed (its tail in the failure otherwise)."""
        code, log = self.wait()
        if code != 0:
            raise AssertionError(f"snakemake on SLURM failed:\n{log[-6000:]}")
        return log

    def stop(self) -> None:
        """End Snakemake and what it started, if it still runs (a test that failed before
        waiting for it); its SLURM jobs end with the cluster."""
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()


class RetryRun(SlurmRun):
    """The retry workflow (`RETRY_SNAKEFILE`, ``--keep-going``) in a new folder ``work``,
    with a watcher thread that cancels (``scancel``) the first running job of its rule
    ``cancelled`` once that job has written its partial output; `cancelled` holds the ids
    it cancelled."""

    def __init__(self, cluster: LocalSlurm, work: Path, *args: str):
        work.mkdir()
        self.cancelled: list[int] = []
        self._done = threading.Event()
        # this checkout's src first on PYTHONPATH: the retry Snakefile reads its resources
        # with workflow/lib/jobresources.py, which imports gbpipe, from a folder without it
        super().__init__(cluster, work, snakemake_env(ROOT), "--snakefile", str(RETRY_SNAKEFILE),
                         "--keep-going", *args)
        self._watcher = threading.Thread(target=self._scancel_first_attempt, args=(cluster,),
                                         daemon=True)
        self._watcher.start()

    def _scancel_first_attempt(self, cluster: LocalSlurm) -> None:
        # acts on the job's state and file, not on time: the sleep is a polling interval
        partial = self.work / "cancelled.txt"
        deadline = time.monotonic() + HANG_S
        while not self._done.is_set() and time.monotonic() < deadline:
            queue = cluster.run("squeue", "-h", "-t", "RUNNING", "-o", "%i|%k|%Z",
                                check=False)
            for jobid, comment, cwd in (x.split("|", 2) for x in queue.stdout.split()):
                if (comment == "rule_cancelled" and Path(cwd).resolve() == self.work.resolve()
                        and partial.exists() and partial.read_text()):
                    cluster.run("scancel", jobid)
                    self.cancelled.append(int(jobid))
                    return
            time.sleep(0.3)

    def wait(self) -> tuple[int, str]:
        try:
            return super().wait()
        finally:
            self._done.set()
            self._watcher.join()

    def stop(self) -> None:
        super().stop()
        self._done.set()
