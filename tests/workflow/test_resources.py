"""Resources per rule: every rule declares threads, memory and run time
(workflow/resources.yaml), writes a benchmark log under its own name, and its jobs'
measured peak memory and wall time stay within the declaration (the CI run and the
bench-record run); the report flags a rule that does not."""

from __future__ import annotations

import importlib.util
import math
import re
import sys
from pathlib import Path

import pytest

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
    # the measurement is real: psutil saw each script's numpy, scipy and xarray (a rule
    # whose every job ended within Snakemake's sampling interval has no memory sample;
    # the SLURM test checks its memory as SLURM accounted it)
    assert all(m.max_rss_mb > 50 for m in measured[run].values() if m.unsampled < m.jobs)


def _benchmark(path: Path, s: float, rss: float) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("s\th:m:s\tmax_rss\tmax_vms\tmax_uss\tmax_pss\tio_in\tio_out\t"
                    f"mean_load\tcpu_time\n{s}\t0:00:01\t{rss}\t1\t1\t1\t0\t0\t90\t{s}\n")


def test_the_report_fails_when_a_rule_exceeds_its_declaration(tmp_path, capsys):
    sim = DECLARED.rules["identify"]
    bench = tmp_path / "results" / "benchmarks"
    _benchmark(bench / "identify" / "a_square.tsv", 10.0, sim["mem_mb"] - 1)
    _benchmark(bench / "kinematics.tsv", 1.0, 100.0)
    assert resources_report.main([str(tmp_path / "results")]) == 0
    # one more job of identify, 1 MB over its declaration: that rule, and only it, fails
    _benchmark(bench / "identify" / "b_square.tsv", 10.0, sim["mem_mb"] + 1)
    assert resources_report.main([str(tmp_path / "results")]) == 1
    out = capsys.readouterr()
    assert "exceeded or undeclared: identify" in out.err
    rows = {r["rule"]: r for r in jobresources.compare(
        DECLARED, jobresources.measured_in(tmp_path / "results"))}
    assert rows["identify"]["status"] == "memory exceeded"
    assert rows["identify"]["jobs"] == 2
    assert rows["kinematics"]["status"] == "ok"
    # too long is flagged too, and a rule nobody declared
    _benchmark(bench / "kinematics.tsv", 60.0 * DECLARED.rules["kinematics"]["runtime"] + 1,
               100.0)
    _benchmark(bench / "mystery.tsv", 1.0, 100.0)
    rows = {r["rule"]: r for r in jobresources.compare(
        DECLARED, jobresources.measured_in(tmp_path / "results"))}
    assert rows["kinematics"]["status"] == "runtime exceeded"
    assert rows["mystery"]["status"] == "undeclared"


def test_a_job_shorter_than_the_sampling_interval_has_no_memory_measurement(tmp_path):
    bench = tmp_path / "results" / "benchmarks"
    short = 0.5 * jobresources.SAMPLE_INTERVAL_S
    # kinematics ended before Snakemake's first sample after its launch: the 2.7 MB are
    # the launcher's, not the script's
    _benchmark(bench / "kinematics.tsv", short, 2.7)
    # identify: one job sampled (180 MB), one too short to be (3 MB)
    _benchmark(bench / "identify" / "a_square.tsv", 2.0, 180.0)
    _benchmark(bench / "identify" / "b_square.tsv", short, 3.0)
    use = jobresources.measured_in(tmp_path / "results")
    assert math.isnan(use["kinematics"].max_rss_mb)
    assert (use["kinematics"].jobs, use["kinematics"].unsampled) == (1, 1)
    assert use["kinematics"].max_wall_s == short
    assert use["identify"].max_rss_mb == 180.0
    assert (use["identify"].jobs, use["identify"].unsampled) == (2, 1)
    rows = {r["rule"]: r for r in jobresources.compare(DECLARED, use)}
    assert rows["kinematics"]["measured_rss_mb"] is None
    assert rows["kinematics"]["unsampled_jobs"] == 1
    assert rows["kinematics"]["status"] == "ok"
    assert rows["identify"]["measured_rss_mb"] == 180.0
    with pytest.raises(ValueError, match="never sampled its memory"):
        jobresources.propose(use["kinematics"], DECLARED.headroom)


def test_several_results_folders_count_together(tmp_path):
    # a study's runs (or the default and the bench-record run) in one report
    for name, rss, s in (("one", 180.0, 2.0), ("two", 250.0, 1.5)):
        _benchmark(tmp_path / name / "benchmarks" / "identify" / "a_square.tsv", s, rss)
    use = jobresources.measured_in(tmp_path / "one", tmp_path / "two")
    assert use["identify"] == jobresources.Measured("identify", 2, 250.0, 2.0, 2.0, 0)


def test_proposal_applies_the_headroom():
    use = jobresources.Measured("x", 3, max_rss_mb=301.0, max_wall_s=200.0, max_cpu_s=150.0)
    head = {"mem": 1.5, "runtime": 3.0, "min_runtime": 5}
    # 1.5 * 301 = 451.5 -> 500 (50 MB steps); 3 * 200 s = 10 min
    assert jobresources.propose(use, head) == {"threads": 1, "mem_mb": 500, "runtime": 10}
    short = jobresources.Measured("y", 1, max_rss_mb=100.0, max_wall_s=2.0, max_cpu_s=1.0)
    assert jobresources.propose(short, head)["runtime"] == 5
