"""Resources per rule: every rule declares threads, memory and run time
(workflow/resources.yaml), writes a benchmark log under its own name, and its jobs'
measured peak memory and wall time stay within the declaration (the CI run and the
bench-record run); the report flags a rule that does not."""

from __future__ import annotations

import importlib.util
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gbpipe.io.runlog import PEAK_LINE, job_resources
from tests.workflow.runs import snakemake_env

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "workflow" / "lib"))
import jobresources  # noqa: E402  (the workflow's own helpers)

# the report script by its path: workflow/scripts on sys.path would shadow test modules
_SPEC = importlib.util.spec_from_file_location(
    "resources_report", ROOT / "workflow" / "scripts" / "resources_report.py")
resources_report = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(resources_report)

DECLARED = jobresources.Declared()


def _workflow_rules() -> set[str]:
    """Every rule of workflow/rules (the target rule `all` of the Snakefile aside)."""
    text = "".join(p.read_text() for p in (ROOT / "workflow" / "rules").glob("*.smk"))
    return set(re.findall(r"(?m)^rule (\w+):", text))


def test_every_rule_is_declared_and_nothing_else():
    assert set(DECLARED.rules) == _workflow_rules()
    for rule, d in DECLARED.rules.items():
        assert d["threads"] >= 1 and d["mem_mb"] > 0 and d["runtime"] > 0, rule


def test_every_rule_reads_its_declaration():
    for path in (ROOT / "workflow" / "rules").glob("*.smk"):
        for block in re.split(r"(?m)^(?=rule \w+:)", path.read_text())[1:]:
            rule = re.match(r"rule (\w+):", block)[1]
            assert f'threads: DECLARED.threads("{rule}")' in block, rule
            assert f'**DECLARED.resources("{rule}")' in block, rule
            bench = re.search(r'benchmark:\n\s+f"\{RESULTS\}/benchmarks/([^"]+)"', block)
            assert bench, f"{rule} writes no benchmark log"
            assert re.match(rf"{rule}(/|\.tsv$)", bench[1]), (rule, bench[1])


def test_a_retry_asks_for_more():
    rule = "sweep"
    res = DECLARED.resources(rule)
    script = DECLARED.rules[rule]["mem_mb"]
    assert res["mem_mb"](None, 1) == script + DECLARED.overhead_mb
    assert res["mem_mb"](None, 2) == 2 * (script + DECLARED.overhead_mb)
    assert res["runtime"](None, 3) == 3 * DECLARED.rules[rule]["runtime"]


def test_bench_record_memory_grows_with_the_record():
    """The rules that hold a bench record ask for memory (and the computing ones for run
    time) growing with their input files' size (Snakemake passes ``input``), an
    hour-long record's GBs on the first attempt; a rule without a declared growth asks
    for the same at any input."""
    class Input:   # Snakemake's InputFiles: its size_mb
        def __init__(self, size_mb: float) -> None:
            self.size_mb = size_mb

    for rule in ("measured", "spectra_measured", "tsa_measured", "modes_measured",
                 "identify_measured", "virtual"):
        slope = DECLARED.per_input_mb[rule]
        assert slope > 0, rule
        res = DECLARED.resources(rule)
        small, big = (res["mem_mb"](None, 1, input=Input(mb)) for mb in (10.0, 1000.0))
        assert big - small == math.ceil(slope * 1000.0) - math.ceil(slope * 10.0), rule
        assert res["mem_mb"](None, 2, input=Input(1000.0)) == 2 * big
        per_min = DECLARED.runtime_per_input_mb[rule]
        assert res["runtime"](None, 1, input=Input(1000.0)) == (
            DECLARED.rules[rule]["runtime"] + math.ceil(per_min * 1000.0))
    assert DECLARED.runtime_per_input_mb["tsa_measured"] > 0
    res = DECLARED.resources("sweep")
    assert res["mem_mb"](None, 1, input=Input(1000.0)) == res["mem_mb"](None, 1)
    assert res["runtime"](None, 1, input=Input(1000.0)) == res["runtime"](None, 1)


@pytest.fixture(scope="module")
def measured(ci_run, measured_run):
    runs = {"ci": jobresources.measured_in(ci_run / "results"),
            "bench records": jobresources.measured_in(measured_run[0] / "results")}
    return runs


def test_every_rule_that_ran_wrote_a_benchmark_log(measured):
    # the two runs together execute every rule of the workflow
    assert set(measured["ci"]) | set(measured["bench records"]) == _workflow_rules()


@pytest.mark.parametrize("run", ["ci", "bench records"])
def test_measured_peak_memory_and_time_within_the_declaration(measured, run):
    rows = jobresources.compare(DECLARED, measured[run])
    over = [(r["rule"], r["status"], r["measured_rss_mb"], r["declared_mem_mb"],
             r["measured_wall_s"], r["declared_runtime_min"])
            for r in rows if r["status"] not in ("ok", "not run")]
    assert over == []
    # every job logged its peak at its exit, and it is real: each script imports numpy
    # and xarray (more than 50 MB resident whatever the machine's load)
    assert {r: m.unmeasured for r, m in measured[run].items()} == dict.fromkeys(
        measured[run], 0)
    assert all(m.max_rss_mb > 50 for m in measured[run].values())


def _benchmark(results: Path, job: str, s: float, rss: float | None,
               log: str | None = None) -> None:
    """A finished job of ``results``: its benchmark log ``benchmarks/<job>.tsv`` (a max_rss
    of 1 MB that must not be read) and its job log (``logs/<log or job>.log``) ending with
    its peak memory ``rss`` [MB] as the job logs it (no such line for None)."""
    path = results / "benchmarks" / f"{job}.tsv"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("s\th:m:s\tmax_rss\tmax_vms\tmax_uss\tmax_pss\tio_in\tio_out\t"
                    f"mean_load\tcpu_time\n{s}\t0:00:01\t1\t1\t1\t1\t0\t0\t90\t{s}\n")
    log_path = results / "logs" / f"{log or job}.log"
    log_path.parent.mkdir(parents=True, exist_ok=True)
    text = "2026-01-01 00:00:00,000 INFO started\n"
    if rss is not None:
        text += f"2026-01-01 00:00:01,000 INFO {PEAK_LINE.format(rss_mb=rss, cpu_s=s)}\n"
    log_path.write_text(text)


def test_the_report_fails_when_a_rule_exceeds_its_declaration(tmp_path, capsys):
    sim = DECLARED.rules["identify"]
    res = tmp_path / "results"
    _benchmark(res, "identify/a_square", 10.0, sim["mem_mb"] - 1)
    _benchmark(res, "kinematics", 1.0, 100.0)
    assert resources_report.main([str(res)]) == 0
    # one more job of identify, 1 MB over its declaration: that rule, and only it, fails
    _benchmark(res, "identify/b_square", 10.0, sim["mem_mb"] + 1)
    assert resources_report.main([str(res)]) == 1
    out = capsys.readouterr()
    assert "exceeded or undeclared: identify" in out.err
    rows = {r["rule"]: r for r in jobresources.compare(DECLARED,
                                                       jobresources.measured_in(res))}
    assert rows["identify"]["status"] == "memory exceeded"
    assert rows["identify"]["jobs"] == 2
    assert rows["identify"]["measured_rss_mb"] == sim["mem_mb"] + 1
    assert rows["kinematics"]["status"] == "ok"
    # too long is flagged too, and a rule nobody declared
    _benchmark(res, "kinematics", 60.0 * DECLARED.rules["kinematics"]["runtime"] + 1, 100.0)
    _benchmark(res, "mystery", 1.0, 100.0)
    rows = {r["rule"]: r for r in jobresources.compare(DECLARED,
                                                       jobresources.measured_in(res))}
    assert rows["kinematics"]["status"] == "runtime exceeded"
    assert rows["mystery"]["status"] == "undeclared"


def test_memory_is_read_from_each_rules_own_job_logs(tmp_path):
    res = tmp_path / "results"
    # the log paths differ from the benchmark paths (rules' log: and benchmark:), and
    # logs/identify/measured/ lies under logs/identify/ without being identify's
    _benchmark(res, "spectra_measured/rec", 0.1, 140.0, log="spectra/measured/rec")
    _benchmark(res, "identify/a_square", 2.0, 180.0)
    _benchmark(res, "identify_measured/rec_pbsid", 1.0, 900.0,
               log="identify/measured/rec_pbsid")
    # a job killed before its end logged no peak: not measured, never 0 MB
    _benchmark(res, "identify/b_square", 0.1, None)
    use = jobresources.measured_in(res)
    assert use["spectra_measured"].max_rss_mb == 140.0
    assert use["identify"].max_rss_mb == 180.0
    assert (use["identify"].jobs, use["identify"].unmeasured) == (2, 1)
    assert use["identify_measured"].max_rss_mb == 900.0
    _benchmark(res, "kinematics", 0.1, None)
    use = jobresources.measured_in(res)
    assert math.isnan(use["kinematics"].max_rss_mb)
    rows = {r["rule"]: r for r in jobresources.compare(DECLARED, use)}
    assert rows["kinematics"]["measured_rss_mb"] is None
    assert rows["kinematics"]["unmeasured_jobs"] == 1
    assert rows["kinematics"]["status"] == "ok"
    with pytest.raises(ValueError, match="no job logged its peak memory"):
        jobresources.propose(use["kinematics"], DECLARED.headroom)


def test_every_rule_has_a_log_path_of_its_own():
    patterns = jobresources.log_patterns()
    assert set(patterns) == _workflow_rules()
    # no path of one rule's logs is another rule's
    examples = {rule: p.pattern.replace("[^/]+", "x").replace("\\", "")
                for rule, p in patterns.items()}
    for rule, path in examples.items():
        assert [r for r, p in patterns.items() if p.fullmatch(path)] == [rule], path


def _job(log: Path, allocate_mb: int, **popen) -> tuple[float, float]:
    """Run a job that sets up its log and holds ``allocate_mb`` MB; what it logged."""
    code = ("import sys, numpy as np\nfrom gbpipe.io import setup_log\n"
            "setup_log(sys.argv[1])\nx = np.ones(int(sys.argv[2]) * 125_000)\n")
    # this checkout's src first on PYTHONPATH, as a job's (the working directory is the
    # log's folder, where no gbpipe is)
    subprocess.run([sys.executable, "-c", code, str(log), str(allocate_mb)], check=True,
                   capture_output=True, cwd=log.parent, env=snakemake_env(ROOT), **popen)
    return job_resources(log)


def test_a_job_logs_its_own_peak_memory_at_exit(tmp_path):
    # a process that holds 300 MB of float64 logs at least that much, whatever the load
    rss, cpu = _job(tmp_path / "big.log", 300)
    assert 300.0 < rss < 1000.0 and cpu >= 0.0
    # a small job forked (as Snakemake starts its jobs) from a parent holding 600 MB
    # logs its own peak, not the parent's (which getrusage's ru_maxrss would carry over)
    parent = np.ones(600 * 125_000)
    small, _ = _job(tmp_path / "small.log", 0, preexec_fn=lambda: None)
    assert parent.sum() > 0 and small < 300.0 < rss


def test_several_results_folders_count_together(tmp_path):
    # a study's runs (or the default and the bench-record run) in one report
    for name, rss, s in (("one", 180.0, 2.0), ("two", 250.0, 1.5)):
        _benchmark(tmp_path / name, "identify/a_square", s, rss)
    use = jobresources.measured_in(tmp_path / "one", tmp_path / "two")
    assert use["identify"] == jobresources.Measured("identify", 2, 250.0, 2.0, 2.0, 0)


def test_proposal_applies_the_headroom():
    use = jobresources.Measured("x", 3, max_rss_mb=301.0, max_wall_s=200.0, max_cpu_s=150.0)
    head = {"mem": 1.5, "runtime": 3.0, "min_runtime": 5}
    # 1.5 * 301 = 451.5 -> 500 (50 MB steps); 3 * 200 s = 10 min
    assert jobresources.propose(use, head) == {"threads": 1, "mem_mb": 500, "runtime": 10}
    short = jobresources.Measured("y", 1, max_rss_mb=100.0, max_wall_s=2.0, max_cpu_s=1.0)
    assert jobresources.propose(short, head)["runtime"] == 5
