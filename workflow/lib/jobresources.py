"""What each rule's job declares (threads, memory, run time) and what it was measured to use.

The declarations live in ``workflow/resources.yaml``, one entry per rule, derived from the
logs of a full default run (``workflow/scripts/resources_report.py --propose``). The rules
read them (``threads: DECLARED.threads("simulate")``, ``resources:
**DECLARED.resources("simulate")``); the report and the tests compare them with the logs
of any run.

Every rule writes its benchmark to ``<results>/benchmarks/<rule>.tsv`` or under
``<results>/benchmarks/<rule>/``, so a log names its rule by its first path component;
its wall and CPU time are read there. Peak memory is what each job logged of itself at
its exit (``gbpipe.io.setup_log``): the script process, not the Snakemake process that
runs it on a cluster node, so each declaration is the script's share plus
``overhead_mb`` (two Snakemake processes per SLURM job: the batch script's and srun's).
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from gbpipe.io.runlog import job_resources

#: The declarations file of the workflow.
DECLARATIONS = Path(__file__).resolve().parents[1] / "resources.yaml"
#: Keys of one rule's declaration.
KEYS = ("threads", "mem_mb", "runtime")
#: The rules of the workflow, whose ``log:`` paths name the rule of each job log.
RULES = Path(__file__).resolve().parents[1] / "rules"

@dataclass(frozen=True)
class Measured:
    """The largest use of one rule's jobs in a run's benchmark logs."""

    rule: str
    jobs: int
    max_rss_mb: float     # peak resident memory of the script process [MB] as each job
                          # logged it at its exit (NaN when no job did)
    max_wall_s: float     # longest job [s]
    max_cpu_s: float      # most CPU time of one job [s]
    unmeasured: int = 0   # jobs whose log holds no peak memory (killed before the end)


class Declared:
    """The rules' declarations of ``workflow/resources.yaml``.

    Parameters
    ----------
    path : path-like
        The declarations file: ``overhead_mb``, ``headroom`` and ``rules: {rule: {threads,
        mem_mb, runtime, mem_mb_per_input_mb?}}`` (memory in MB for the rule's script,
        run time in minutes; ``mem_mb_per_input_mb`` [MB per MB] and
        ``runtime_per_input_mb`` [min per MB], where a rule's memory and time grow with
        its record, are added per MB of the job's input files).
    """

    def __init__(self, path: str | Path = DECLARATIONS) -> None:
        with open(path) as fh:
            data = yaml.safe_load(fh)
        self.path = Path(path)
        self.overhead_mb = int(data["overhead_mb"])
        self.headroom = {k: float(v) for k, v in data["headroom"].items()}
        self.rules: dict[str, dict[str, int]] = {}
        self.per_input_mb: dict[str, float] = {}
        self.runtime_per_input_mb: dict[str, float] = {}
        for rule, entry in data["rules"].items():
            missing = [k for k in KEYS if k not in entry]
            if missing:
                raise ValueError(f"{path}: rule {rule} declares no {missing}")
            self.rules[rule] = {k: int(entry[k]) for k in KEYS}
            self.per_input_mb[rule] = float(entry.get("mem_mb_per_input_mb", 0.0))
            self.runtime_per_input_mb[rule] = float(entry.get("runtime_per_input_mb", 0.0))

    def _entry(self, rule: str) -> dict[str, int]:
        try:
            return self.rules[rule]
        except KeyError:
            raise KeyError(f"rule {rule} has no entry in {self.path}; measure it with "
                           "workflow/scripts/resources_report.py --propose") from None

    def threads(self, rule: str) -> int:
        """Threads (cores) of one job of ``rule``."""
        return self._entry(rule)["threads"]

    def mem_mb(self, rule: str, attempt: int = 1, input_mb: float = 0.0) -> int:
        """Memory of one job of ``rule`` on its ``attempt``-th try [MB]: the script's
        share (with its growth with the job's ``input_mb`` [MB] of input files, where
        declared) plus the Snakemake overhead, times the attempt (a retry asks for more)."""
        grows = math.ceil(self.per_input_mb[rule] * input_mb) if input_mb else 0
        return (self._entry(rule)["mem_mb"] + grows + self.overhead_mb) * attempt

    def runtime(self, rule: str, attempt: int = 1, input_mb: float = 0.0) -> int:
        """Wall-time limit of one job of ``rule`` on its ``attempt``-th try [min] (with its
        growth with the job's ``input_mb`` [MB] of input files, where declared)."""
        grows = math.ceil(self.runtime_per_input_mb[rule] * input_mb) if input_mb else 0
        return (self._entry(rule)["runtime"] + grows) * attempt

    def resources(self, rule: str) -> dict[str, Callable[..., int]]:
        """The ``resources:`` of ``rule``: memory and run time growing with the attempt,
        the memory also with the size of the job's input (Snakemake passes ``input``)."""
        self._entry(rule)   # an undeclared rule fails when the workflow is parsed
        return {"mem_mb": lambda wildcards, attempt, input=None: self.mem_mb(
                    rule, attempt, input.size_mb if input is not None else 0.0),
                "runtime": lambda wildcards, attempt, input=None: self.runtime(
                    rule, attempt, input.size_mb if input is not None else 0.0)}


def rule_of(benchmark: Path, root: Path) -> str:
    """The rule a benchmark log belongs to: its first path component under ``root``."""
    first = benchmark.relative_to(root).parts[0]
    return first.removesuffix(".tsv")


def read_benchmark(path: Path) -> dict[str, float]:
    """Wall and CPU time of the last row of one Snakemake benchmark log (one row per
    repeat). Its ``max_rss`` is not used: Snakemake samples it every 0.5 s, so a short
    job's is its launcher's or missing, depending on the machine's load."""
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh, delimiter="\t"))
    if not rows:
        raise ValueError(f"benchmark log {path} has no row")
    row = rows[-1]
    return {"s": float(row["s"]), "cpu_time": float(row["cpu_time"])}


def log_patterns(rules: Path = RULES) -> dict[str, re.Pattern]:
    """Rule -> regular expression of its job logs' paths under the results folder, from
    the ``log:`` of each rule in ``rules/*.smk`` (a wildcard matches one path part)."""
    out = {}
    for path in sorted(rules.glob("*.smk")):
        for block in re.split(r"(?m)^(?=rule \w+:)", path.read_text())[1:]:
            rule = re.match(r"rule (\w+):", block)[1]
            found = re.search(r'\n    log:\n\s+f"\{RESULTS\}/([^"]+)"', block)
            if found:
                parts = re.split(r"\{\{\w+\}\}", found[1])
                out[rule] = re.compile("[^/]+".join(map(re.escape, parts)))
    return out


def measured_in(*results: str | Path, rules: Path = RULES) -> dict[str, Measured]:
    """Per rule, the largest use over its jobs in one or several results folders (a
    study's runs, the default and the bench-record run count together).

    Wall and CPU time come from the jobs' ``benchmarks/`` logs (the first path component
    there names the rule); peak memory from the jobs' own logs under ``logs/``
    (:func:`gbpipe.io.runlog.job_resources`, kernel accounting, the same however loaded
    the machine). A job without that line is counted in ``unmeasured``, never as using
    0 MB.
    """
    patterns = log_patterns(rules)
    times: dict[str, list[dict[str, float]]] = {}
    peaks: dict[str, list[float]] = {}
    for folder in map(Path, results):
        root = folder / "benchmarks"
        for path in sorted(root.rglob("*.tsv")):
            times.setdefault(rule_of(path, root), []).append(read_benchmark(path))
        for path in sorted((folder / "logs").rglob("*.log")):
            rel = path.relative_to(folder).as_posix()
            rule = next((r for r, p in patterns.items() if p.fullmatch(rel)), None)
            use = job_resources(path)
            if rule is not None and use is not None:
                peaks.setdefault(rule, []).append(use[0])
    return {rule: Measured(rule, len(r), max(peaks.get(rule, []), default=math.nan),
                           max(x["s"] for x in r), max(x["cpu_time"] for x in r),
                           unmeasured=max(0, len(r) - len(peaks.get(rule, []))))
            for rule, r in sorted(times.items())}


def propose(use: Measured, headroom: Mapping[str, float]) -> dict[str, int]:
    """A declaration from measured use: memory and run time times their headroom, memory
    rounded up to 50 MB, run time to whole minutes (at least ``headroom['min_runtime']``);
    one thread (Snakemake sets the BLAS threads of a job to its ``threads``).

    Raises
    ------
    ValueError
        No job of the rule logged its peak memory.
    """
    if math.isnan(use.max_rss_mb):
        raise ValueError(f"rule {use.rule}: no job logged its peak memory (each job's log "
                         "ends with it when the job exits); keep its declaration")
    mem = 50 * math.ceil(headroom["mem"] * use.max_rss_mb / 50)
    runtime = max(int(headroom["min_runtime"]),
                  math.ceil(headroom["runtime"] * use.max_wall_s / 60))
    return {"threads": 1, "mem_mb": mem, "runtime": runtime}


def compare(declared: Declared, use: Mapping[str, Measured]) -> list[dict[str, Any]]:
    """One row per declared or measured rule: measured against declared, and whether the
    measured peak memory and wall time fit in the first attempt's declaration.
    ``unmeasured_jobs`` counts the jobs that logged no peak memory; a rule with only such
    jobs is judged on its run time."""
    rows = []
    for rule in sorted(set(declared.rules) | set(use)):
        d, m = declared.rules.get(rule), use.get(rule)
        row: dict[str, Any] = {"rule": rule, "jobs": m.jobs if m else 0}
        row["threads"] = d["threads"] if d else None
        row["declared_mem_mb"] = d["mem_mb"] if d else None
        row["measured_rss_mb"] = (round(m.max_rss_mb, 1)
                                  if m and not math.isnan(m.max_rss_mb) else None)
        row["unmeasured_jobs"] = m.unmeasured if m else 0
        row["declared_runtime_min"] = d["runtime"] if d else None
        row["measured_wall_s"] = round(m.max_wall_s, 2) if m else None
        row["measured_cpu_s"] = round(m.max_cpu_s, 2) if m else None
        if d is None:
            row["status"] = "undeclared"
        elif m is None:
            row["status"] = "not run"
        elif m.max_rss_mb > d["mem_mb"]:   # False for NaN: no job logged its memory
            row["status"] = "memory exceeded"
        elif m.max_wall_s > 60 * d["runtime"]:
            row["status"] = "runtime exceeded"
        else:
            row["status"] = "ok"
        rows.append(row)
    return rows
