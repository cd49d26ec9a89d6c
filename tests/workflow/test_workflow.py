"""The Snakemake workflow end to end on the CI config, in a scratch copy of the repository.

One complete CI run (``ci_run``, tests/conftest.py) is shared by the tests below:
a dry run with nothing left to do, the exact rerun after a TSA parameter changes, output
permissions, CF compliance and provenance of every NetCDF output, and the HTML report
rendered in a real headless browser. Reproducibility across runs is checked by
test_interrupt.py (a killed and resumed run gives the results of this one).
"""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import stat
import subprocess
from collections import Counter
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest
from playwright.sync_api import sync_playwright

import gbpipe
from gbpipe import io
from tests.conftest import apt_lock
from tests.workflow.cf_check import cf_findings_of_files
from tests.workflow.runs import ROOT, snakemake

#: A date and clock time, as a file written with the time in it would hold
CLOCK = re.compile(r"\d{4}-\d\d-\d\d[T ]\d\d:\d\d")


def _outputs(run: Path) -> list[Path]:
    return sorted((run / "results").rglob("*.nc"))


def test_dry_run_after_complete_run_has_nothing_to_do(ci_run):
    out = snakemake(ci_run, "--dry-run")
    assert "Nothing to be done" in out.stdout + out.stderr


def planned_jobs(output: str) -> Counter:
    """Rule -> job count of the 'Job stats' table of a dry run (empty: nothing to do)."""
    jobs, table = Counter(), False
    for line in output.splitlines():
        if line.startswith("job") and "count" in line:
            table = True
            continue
        if table:
            m = re.match(r"^([A-Za-z_]\w*)\s+(\d+)\s*$", line.strip())
            if m and m.group(1) != "total":
                jobs[m.group(1)] = int(m.group(2))
            elif m is None and jobs:
                break
    return jobs


def _rules_with_param(key: str) -> set[str]:
    """Rules whose ``params:`` name ``key`` (read from workflow/rules/*.smk)."""
    found = set()
    for path in (ROOT / "workflow" / "rules").glob("*.smk"):
        for block in re.split(r"(?m)^(?=rule \w+:)", path.read_text())[1:]:
            params = re.search(r"\n    params:\n(.*?)\n    \w+:", block, re.S)
            if params and key in params[1]:
                found.add(re.match(r"rule (\w+):", block)[1])
    return found


def test_changed_tsa_parameter_reruns_exactly_the_jobs_that_use_it(ci_run):
    # tsa.n_cycles is a parameter of the rules that name it in their params: (the sweep's
    # TSA variants, their figures, the TSA of the test records); changing it must rerun
    # exactly those rules' jobs and everything downstream of them (what Snakemake plans
    # when those rules are forced), nothing upstream, no sibling. The expectation is
    # derived from the rule files, so adding a rule does not break the test.
    readers = _rules_with_param("n_cycles")
    assert {"tsa", "removal_tests"} <= readers
    overlay = ci_run / "config" / "tsa_change.yaml"
    overlay.write_text("tsa:\n  n_cycles: 8\n")
    try:
        out = snakemake(ci_run, "config/tsa_change.yaml", "--dry-run")
    finally:
        overlay.unlink()
    forced = snakemake(ci_run, "--dry-run", "--forcerun", *sorted(readers))
    planned, expected = (planned_jobs(o.stdout + o.stderr) for o in (out, forced))
    assert planned == expected
    # what the closure holds in the CI run: the TSA of the sweep and the records, their
    # identification downstream; and nothing upstream of the TSA
    assert {"tsa", "removal_tests", "identify", "fit"} <= set(planned)
    assert not {"kinematics", "model", "campaign", "sweep", "spectra"} & set(planned)


def test_every_output_file_is_0644(ci_run):
    files = [p for p in (ci_run / "results").rglob("*") if p.is_file()]
    assert len(files) >= 60
    modes = {str(p.relative_to(ci_run)): oct(stat.S_IMODE(p.stat().st_mode)) for p in files}
    assert {k: v for k, v in modes.items() if v != "0o644"} == {}
    assert not list((ci_run / "results").rglob("*.tmp")), "temporaries left behind"


def test_every_netcdf_output_is_cf_clean(ci_run):
    paths = _outputs(ci_run)
    findings = {str(p.relative_to(ci_run)): f
                for p, f in zip(paths, cf_findings_of_files(paths), strict=True)}
    assert findings and not any(findings.values()), {k: v for k, v in findings.items() if v}


def test_every_output_has_provenance(ci_run):
    # the values, checked independently: the version installed, the hash of the config
    # slice the file holds (hashlib over its canonical JSON), each source file's size and
    # hash as they are on disk, a creation time in UTC
    for path in _outputs(ci_run):
        ds = io.read(path)
        a = ds.attrs
        assert a["Conventions"] == "CF-1.11" and a["gbpipe_version"] == gbpipe.__version__
        assert a["source"] == f"gbpipe {gbpipe.__version__} stage '{a['stage']}'", path
        canonical = json.dumps(json.loads(a["config"]), sort_keys=True,
                               separators=(",", ":"))
        assert a["config_sha256"] == hashlib.sha256(canonical.encode()).hexdigest(), path
        sources = json.loads(a["source_files"])
        assert sources, path
        for src in sources:
            data = (ci_run / src["path"]).read_bytes()
            assert (len(data), hashlib.sha256(data).hexdigest()) == (
                src["bytes"], src["sha256"]), (path, src["path"])
        # no clock time in the file (the same config gives the same bytes): the history
        # names the version and stage, not when
        assert a["history"].splitlines()[-1] == f"gbpipe {gbpipe.__version__} {a['stage']}"
        assert not [k for k, v in a.items() if CLOCK.search(str(v))], path
        for name, var in {**ds.coords, **ds.data_vars}.items():
            assert var.attrs["units"] and var.attrs["long_name"], (path, name)


@pytest.fixture(scope="session")
def chromium() -> str:
    """Debian's chromium; installed here when missing (as the test command promises)."""
    path = shutil.which("chromium")
    if path is None:
        env = {"DEBIAN_FRONTEND": "noninteractive", "PATH": "/usr/sbin:/usr/bin:/sbin:/bin"}
        with apt_lock():   # the SLURM install may be running in the background
            for cmd in (["apt-get", "update", "-qq"],
                        ["apt-get", "install", "-y", "-qq", "chromium"]):
                proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
                assert proc.returncode == 0, f"{' '.join(cmd)} failed: {proc.stderr[-2000:]}"
        path = shutil.which("chromium")
    assert path, "chromium is not installed and could not be installed with apt-get"
    return path


def test_report_renders_every_figure_in_a_browser(ci_run, chromium, tmp_path):
    report = ci_run / "results" / "report.html"
    snakemake(ci_run, "--report", str(report))
    expected = sorted(p.stem + ".png" for p in (ci_run / "results" / "report").glob("*.rst"))
    assert len(expected) >= 15
    args = ["--no-sandbox", "--disable-gpu", "--disable-background-networking",
            "--disable-component-update", "--disable-sync", "--no-first-run"]
    seen = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=args)
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        page.goto(report.as_uri())
        categories = [c.strip() for c in page.locator("body").inner_text().split("\n")]
        for cat in ("Model", "Test campaigns", "Harmonic removal", "Identification",
                    "Physical fit"):
            if cat not in categories:
                continue
            page.goto(report.as_uri())
            page.get_by_text(cat, exact=True).first.click()
            rows = page.locator("tr", has_text=".png")
            for i in range(rows.count()):
                row = rows.nth(i)
                name = row.inner_text().split("/")[-1].strip()
                row.locator("a[iconname=eye]").click()
                png = mpimg.imread(ci_run / "results" / "figures" / name)
                # wait for the figure itself (its decoded width), not for a fixed time: a
                # loaded machine only makes this slower; the timeout is there for a hang
                page.wait_for_function(
                    "w => [...document.querySelectorAll(\"img[src^='data:image/png']\")]"
                    ".some(e => e.complete && e.naturalWidth === w)", arg=png.shape[1],
                    timeout=300_000)
                shot = tmp_path / f"shot_{name}"
                page.screenshot(path=str(shot))
                pixels = mpimg.imread(shot)[:, 400:, :3]
                # a rendered plot has ink: many distinct grey levels, not a blank panel
                assert pixels.std() > 0.05 and len(np.unique(pixels.round(2))) > 50, name
                seen.append(name)
        browser.close()
    assert sorted(seen) == expected
