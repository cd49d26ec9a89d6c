"""Snakemake runs on the local SLURM of tests/cluster, and their jobs as sacct has them."""

from __future__ import annotations

import re
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

from slurm_local import LocalSlurm

from tests.conftest import ROOT

#: The repository's SLURM profile (what a user runs).
PROFILE = ROOT / "profiles" / "slurm"
#: Seconds before the executor's first status query (its default, 40 s, suits a big
#: cluster's controller; a one-node test cluster answers at once).
FAST_STATUS = ["--slurm-init-seconds-before-status-checks", "2"]
#: Rule -> (largest peak memory of its SLURM jobs as sacct accounted it, Snakemake
#: included; memory its jobs asked for) [MB]: filled by the tests, printed at the end.
MEMORY: dict[str, tuple[float, int]] = {}


def last_job_id(cluster: LocalSlurm) -> int:
    """The highest job id the cluster has accounted for (0 before the first job)."""
    return max(slurm_jobs(cluster, after=0), default=0)


def slurm_jobs(cluster: LocalSlurm, after: int) -> dict[int, dict]:
    """Jobs with an id above ``after``, from ``sacct``: id -> rule (from the comment that
    Snakemake's executor sets), the states of the job and of its steps, memory asked [MB],
    and ``rss_mb``: the sum of its steps' peak resident memory [MB] (the batch script's
    Snakemake and the srun step with the rule's script run at once, so the sum bounds the
    job's peak from above).
    """
    out = cluster.run("sacct", "-a", "-n", "-P", "-S", "2000-01-01", "-o",
                      "JobIDRaw,State,ReqMem,MaxRSS,Comment").stdout
    jobs: dict[int, dict] = defaultdict(lambda: {"states": [], "rss_mb": 0.0})
    for line in out.splitlines():
        jobid, state, reqmem, maxrss, comment = line.split("|", 4)
        main = int(jobid.split(".")[0])
        if main <= after:
            continue
        jobs[main]["states"].append(state.split()[0])  # "CANCELLED by 0" -> CANCELLED
        if maxrss:
            jobs[main]["rss_mb"] += _megabytes(maxrss, "K")
        if "." not in jobid:
            rule = re.match(r"rule_(\w+?)(?:_wildcards_.*)?$", comment)
            jobs[main]["rule"] = rule.group(1) if rule else comment
            jobs[main]["mem_mb"] = round(_megabytes(reqmem))
    return dict(jobs)


def _megabytes(amount: str, bare: str = "M") -> float:
    # sacct prints e.g. 2000M or 4G (22.05: no trailing n/c), MaxRSS e.g. 123456K or 0
    if amount[-1].isdigit():
        amount += bare
    value, unit = float(amount[:-1]), amount[-1]
    return value * {"K": 1 / 1024, "M": 1, "G": 1024, "T": 1024**2}[unit]


def snakemake_on_slurm(cluster: LocalSlurm, work: Path, env: dict[str, str], *args: str,
                       check: bool = True) -> subprocess.CompletedProcess:
    """``snakemake --profile profiles/slurm ARGS`` in ``work``: every job a SLURM job."""
    proc = subprocess.run([sys.executable, "-m", "snakemake", "--profile", str(PROFILE),
                           *FAST_STATUS, *args], cwd=work, capture_output=True, text=True,
                          env=cluster.client_env(env))
    if check and proc.returncode != 0:
        raise AssertionError(f"snakemake on SLURM failed:\n{proc.stderr[-6000:]}")
    return proc
