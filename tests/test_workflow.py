"""The Snakemake workflow end to end on the CI config, in a scratch copy of the repository.

One full run is shared by the tests below: reproducibility across two runs, a dry run with
nothing left to do, the minimal rerun after a TSA parameter changes, CF compliance of every
NetCDF output, and the HTML report rendered in a real headless browser.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import xarray as xr

from gbpipe import io

from .cf_check import cf_findings
from .conftest import ROOT

SNAKEMAKE = [sys.executable, "-m", "snakemake", "--cores", "2", "--configfile",
             "config/ci.yaml"]


def _copy_repo(dest: Path) -> Path:
    """Copy the tracked and untracked-but-not-ignored files: a fresh clone's content."""
    files = subprocess.run(["git", "ls-files", "-co", "--exclude-standard", "-z"], cwd=ROOT,
                           check=True, capture_output=True).stdout.decode().split("\0")
    for f in filter(None, files):
        src = ROOT / f
        if src.is_file():
            (dest / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / f, follow_symlinks=False)
    return dest


def _snakemake(cwd: Path, *args: str, check: bool = True) -> subprocess.CompletedProcess:
    proc = subprocess.run([*SNAKEMAKE, *args], cwd=cwd, capture_output=True, text=True)
    if check and proc.returncode != 0:
        raise AssertionError(f"snakemake {' '.join(args)} failed:\n{proc.stderr[-6000:]}")
    return proc


@pytest.fixture(scope="session")
def ci_run(tmp_path_factory) -> Path:
    work = _copy_repo(tmp_path_factory.mktemp("ci_run"))
    _snakemake(work)
    return work


def _outputs(run: Path) -> list[Path]:
    return sorted((run / "results").rglob("*.nc"))


def test_two_runs_give_equal_results(ci_run, tmp_path_factory):
    again = _copy_repo(tmp_path_factory.mktemp("ci_run_again"))
    _snakemake(again)
    first = _outputs(ci_run)
    assert len(first) >= 10
    assert [p.relative_to(ci_run) for p in first] == [
        p.relative_to(again) for p in _outputs(again)]
    for path in first:
        a, b = io.read(path), io.read(again / path.relative_to(ci_run))
        xr.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-9)
        assert a.attrs["config_sha256"] == b.attrs["config_sha256"]


def test_dry_run_after_complete_run_has_nothing_to_do(ci_run):
    out = _snakemake(ci_run, "--dry-run")
    assert "Nothing to be done" in out.stdout + out.stderr


def _planned_rules(output: str) -> set[str]:
    """Rule names of the 'Job stats' table of a dry run."""
    rules, table = set(), False
    for line in output.splitlines():
        if line.startswith("job") and "count" in line:
            table = True
            continue
        if table:
            m = re.match(r"^([A-Za-z_]\w*)\s+\d+\s*$", line.strip())
            if m and m.group(1) != "total":
                rules.add(m.group(1))
            elif line.strip() == "" and rules:
                break
    return rules


def test_changed_tsa_parameter_reruns_only_tsa_and_downstream(ci_run):
    overlay = ci_run / "config" / "tsa_change.yaml"
    overlay.write_text("tsa:\n  n_cycles: 8\n")
    out = _snakemake(ci_run, "config/tsa_change.yaml", "--dry-run")
    planned = _planned_rules(out.stdout + out.stderr)
    assert "tsa" in planned
    upstream = {"kinematics", "model", "simulate", "sweep", "spectra", "figures_model",
                "figures_tests"}
    assert not planned & upstream, f"upstream rules would rerun: {planned & upstream}"
    overlay.unlink()


def test_every_netcdf_output_is_cf_clean(ci_run):
    findings = {str(p.relative_to(ci_run)): cf_findings(p) for p in _outputs(ci_run)}
    assert findings and not any(findings.values()), {k: v for k, v in findings.items() if v}


def test_every_output_has_provenance(ci_run):
    for path in _outputs(ci_run):
        ds = io.read(path)
        for key in ("gbpipe_version", "config_sha256", "created", "stage", "Conventions"):
            assert key in ds.attrs, (path, key)
        for name, var in {**ds.coords, **ds.data_vars}.items():
            assert "units" in var.attrs and "long_name" in var.attrs, (path, name)


@pytest.fixture(scope="session")
def chromium() -> str:
    """Debian's chromium; installed here when missing (as the test command promises)."""
    path = shutil.which("chromium")
    if path is None:
        env = {"DEBIAN_FRONTEND": "noninteractive", "PATH": "/usr/sbin:/usr/bin:/sbin:/bin"}
        for cmd in (["apt-get", "update", "-qq"], ["apt-get", "install", "-y", "-qq", "chromium"]):
            proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
            assert proc.returncode == 0, f"{' '.join(cmd)} failed: {proc.stderr[-2000:]}"
        path = shutil.which("chromium")
    assert path, "chromium is not installed and could not be installed with apt-get"
    return path


def test_report_renders_every_figure_in_a_browser(ci_run, chromium, tmp_path):
    import matplotlib.image as mpimg
    import numpy as np
    from playwright.sync_api import sync_playwright

    report = ci_run / "results" / "report.html"
    _snakemake(ci_run, "--report", str(report))
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
        for cat in ("Model", "Test campaigns", "Harmonic removal", "Identification"):
            if cat not in categories:
                continue
            page.goto(report.as_uri())
            page.get_by_text(cat, exact=True).first.click()
            rows = page.locator("tr", has_text=".png")
            for i in range(rows.count()):
                row = rows.nth(i)
                name = row.inner_text().split("/")[-1].strip()
                row.locator("a[iconname=eye]").click()
                page.wait_for_timeout(300)
                sizes = page.eval_on_selector_all(
                    "img[src^='data:image/png']", "els => els.map(e => e.naturalWidth)")
                png = mpimg.imread(ci_run / "results" / "figures" / name)
                assert png.shape[1] in sizes, f"{name} did not render (widths {sizes})"
                shot = tmp_path / f"shot_{name}"
                page.screenshot(path=str(shot))
                pixels = mpimg.imread(shot)[:, 400:, :3]
                # a rendered plot has ink: many distinct grey levels, not a blank panel
                assert pixels.std() > 0.05 and len(np.unique(pixels.round(2))) > 50, name
                seen.append(name)
        browser.close()
    assert sorted(seen) == expected
