"""What each rule's job declares (threads, memory, run time) and what it was measured to use.

The declarations live in ``workflow/resources.yaml``, one entry per rule, derived from the
``benchmark:`` logs of a full default run (``workflow/scripts/resources_report.py
--propose``). The rules read them (``threads: DECLARED.threads("simulate")``,
``resources: **DECLARED.resources("simulate")``); the report and the tests compare them
with the benchmark logs of any run.

Every rule writes its benchmark to ``<results>/benchmarks/<rule>.tsv`` or under
``<results>/benchmarks/<rule>/``, so a log names its rule by its first path component.
Snakemake's benchmark measures the job's script process (tree), not the Snakemake
process that runs it on a cluster node, so each declaration is the script's share plus
``overhead_mb`` (two Snakemake processes per SLURM job: the batch script's and srun's).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml
from snakemake.benchmark import BENCHMARK_INTERVAL_SHORT

#: The declarations file of the workflow.
DECLARATIONS = Path(__file__).resolve().parents[1] / "resources.yaml"
#: Keys of one rule's declaration.
KEYS = ("threads", "mem_mb", "runtime")
#: Snakemake's benchmark samples a job's processes when it starts, then every this many
#: seconds: a job that ends sooner has only its launch sampled (the launcher's few MB and
#: no CPU, never the script), so its memory is not measured at all.
SAMPLE_INTERVAL_S = float(BENCHMARK_INTERVAL_SHORT)


@dataclass(frozen=True)
class Measured:
    """The largest use of one rule's jobs in a run's benchmark logs."""

    rule: str
    jobs: int
    max_rss_mb: float     # peak resident memory of the script's process tree [MB], over
                          # the sampled jobs (NaN when none was)
    max_wall_s: float     # longest job [s]
    max_cpu_s: float      # most CPU time of one job [s]
    unsampled: int = 0    # jobs shorter than SAMPLE_INTERVAL_S: memory not measured


class Declared:
    """The rules' declarations of ``workflow/resources.yaml``.

    Parameters
    ----------
    path : path-like
        The declarations file: ``overhead_mb``, ``headroom`` and ``rules: {rule: {threads,
        mem_mb, runtime}}`` (memory in MB for the rule's script, run time in minutes).
    """

    def __init__(self, path: str | Path = DECLARATIONS) -> None:
        with open(path) as fh:
            data = yaml.safe_load(fh)
        self.path = Path(path)
        self.overhead_mb = int(data["overhead_mb"])
        self.headroom = {k: float(v) for k, v in data["headroom"].items()}
        self.rules: dict[str, dict[str, int]] = {}
        for rule, entry in data["rules"].items():
            missing = [k for k in KEYS if k not in entry]
            if missing:
                raise ValueError(f"{path}: rule {rule} declares no {missing}")
            self.rules[rule] = {k: int(entry[k]) for k in KEYS}

    def _entry(self, rule: str) -> dict[str, int]:
        try:
            return self.rules[rule]
        except KeyError:
            raise KeyError(f"rule {rule} has no entry in {self.path}; measure it with "
                           "workflow/scripts/resources_report.py --propose") from None

    def threads(self, rule: str) -> int:
        """Threads (cores) of one job of ``rule``."""
        return self._entry(rule)["threads"]

    def mem_mb(self, rule: str, attempt: int = 1) -> int:
        """Memory of one job of ``rule`` on its ``attempt``-th try [MB]: the script's
        share plus the Snakemake overhead, times the attempt (a retry asks for more)."""
        return (self._entry(rule)["mem_mb"] + self.overhead_mb) * attempt

    def runtime(self, rule: str, attempt: int = 1) -> int:
        """Wall-time limit of one job of ``rule`` on its ``attempt``-th try [min]."""
        return self._entry(rule)["runtime"] * attempt

    def resources(self, rule: str) -> dict[str, Callable[..., int]]:
        """The ``resources:`` of ``rule``: memory and run time growing with the attempt."""
        self._entry(rule)   # an undeclared rule fails when the workflow is parsed
        return {"mem_mb": lambda wildcards, attempt: self.mem_mb(rule, attempt),
                "runtime": lambda wildcards, attempt: self.runtime(rule, attempt)}


def rule_of(benchmark: Path, root: Path) -> str:
    """The rule a benchmark log belongs to: its first path component under ``root``."""
    first = benchmark.relative_to(root).parts[0]
    return first.removesuffix(".tsv")


def read_benchmark(path: Path) -> dict[str, float]:
    """The last row of one Snakemake benchmark log (one row per repeat)."""
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh, delimiter="\t"))
    if not rows:
        raise ValueError(f"benchmark log {path} has no row")
    row = rows[-1]
    return {"s": float(row["s"]), "max_rss": float(row["max_rss"]),
            "cpu_time": float(row["cpu_time"])}


def measured(benchmarks: Iterable[tuple[Path, Path]]) -> dict[str, Measured]:
    """Per rule, the largest use over its jobs' benchmark logs.

    ``benchmarks`` are ``(log, root)`` pairs, ``root`` the ``benchmarks`` folder the log
    lies under (its first path component there names the rule), so that the logs of
    several results folders (a study's runs, the default and the bench-record run) count
    together. Memory that psutil could not read is written as ``NA`` by Snakemake and
    raises here: a measurement that is missing is not a measurement of zero. A job
    shorter than :data:`SAMPLE_INTERVAL_S` is counted in ``unsampled`` and left out of
    the peak memory (its only sample is its launch), never taken as using a few MB.
    """
    rows: dict[str, list[dict[str, float]]] = {}
    for path, root in benchmarks:
        rows.setdefault(rule_of(path, root), []).append(read_benchmark(path))
    out = {}
    for rule, r in sorted(rows.items()):
        sampled = [x["max_rss"] for x in r if x["s"] >= SAMPLE_INTERVAL_S]
        out[rule] = Measured(rule, len(r), max(sampled, default=math.nan),
                             max(x["s"] for x in r), max(x["cpu_time"] for x in r),
                             unsampled=len(r) - len(sampled))
    return out


def measured_in(*results: str | Path) -> dict[str, Measured]:
    """:func:`measured` of every benchmark log of one or several results folders."""
    roots = [Path(folder) / "benchmarks" for folder in results]
    return measured((path, root) for root in roots for path in sorted(root.rglob("*.tsv")))


def propose(use: Measured, headroom: Mapping[str, float]) -> dict[str, int]:
    """A declaration from measured use: memory and run time times their headroom, memory
    rounded up to 50 MB, run time to whole minutes (at least ``headroom['min_runtime']``);
    one thread (Snakemake sets the BLAS threads of a job to its ``threads``).

    Raises
    ------
    ValueError
        No job of the rule was long enough for its memory to be sampled.
    """
    if math.isnan(use.max_rss_mb):
        raise ValueError(f"rule {use.rule}: no job ran {SAMPLE_INTERVAL_S} s or longer, so "
                         "Snakemake never sampled its memory; keep its declaration or "
                         "measure it on a slower run")
    mem = 50 * math.ceil(headroom["mem"] * use.max_rss_mb / 50)
    runtime = max(int(headroom["min_runtime"]),
                  math.ceil(headroom["runtime"] * use.max_wall_s / 60))
    return {"threads": 1, "mem_mb": mem, "runtime": runtime}


def compare(declared: Declared, use: Mapping[str, Measured]) -> list[dict[str, Any]]:
    """One row per declared or measured rule: measured against declared, and whether the
    measured peak memory and wall time fit in the first attempt's declaration.
    ``unsampled_jobs`` counts the jobs whose memory Snakemake never sampled (shorter than
    :data:`SAMPLE_INTERVAL_S`); a rule with only such jobs is judged on its run time."""
    rows = []
    for rule in sorted(set(declared.rules) | set(use)):
        d, m = declared.rules.get(rule), use.get(rule)
        row: dict[str, Any] = {"rule": rule, "jobs": m.jobs if m else 0}
        row["threads"] = d["threads"] if d else None
        row["declared_mem_mb"] = d["mem_mb"] if d else None
        row["measured_rss_mb"] = (round(m.max_rss_mb, 1)
                                  if m and not math.isnan(m.max_rss_mb) else None)
        row["unsampled_jobs"] = m.unsampled if m else 0
        row["declared_runtime_min"] = d["runtime"] if d else None
        row["measured_wall_s"] = round(m.max_wall_s, 2) if m else None
        row["measured_cpu_s"] = round(m.max_cpu_s, 2) if m else None
        if d is None:
            row["status"] = "undeclared"
        elif m is None:
            row["status"] = "not run"
        elif m.max_rss_mb > d["mem_mb"]:   # False for NaN: no job's memory was sampled
            row["status"] = "memory exceeded"
        elif m.max_wall_s > 60 * d["runtime"]:
            row["status"] = "runtime exceeded"
        else:
            row["status"] = "ok"
        rows.append(row)
    return rows
