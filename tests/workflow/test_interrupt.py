"""A run killed with SIGKILL, then resumed as the README says, gives the results of an
uninterrupted run, and leaves no temporaries behind.

The CI workflow is started in a fresh copy; once an ``identify`` job is working (its log
holds its first record; each takes ~15 s) the whole process group (Snakemake and its
jobs) gets SIGKILL:
no handler runs,
the lock and any half-written temporary stay. One more temporary, as a job killed while
writing leaves it, is planted so the clean-up is always exercised. Then the README's
recovery: ``snakemake --unlock``, then ``snakemake --rerun-incomplete``. Every NetCDF
output must equal the uninterrupted run's (``ci_run``), every CSV table byte for byte.
"""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import xarray as xr

from gbpipe import io
from tests.workflow.runs import copy_repo, snakemake, start_snakemake

#: Seconds to wait for the job to start: only a hang gets near it (the whole CI run takes
#: about two minutes on 2 idle cores).
_START_TIMEOUT = 1800.0


def _kill_when_running(work: Path, log: Path, markers: str) -> None:
    """Start the CI workflow in ``work``; SIGKILL it once a job log matching ``markers``
    holds a record: the job is then past its imports and inside its work (an identify
    job logs its first line after its first fitted model, well before its end), however
    fast or loaded the machine (an event, not a fixed sleep)."""
    proc = start_snakemake(work, log)
    deadline = time.monotonic() + _START_TIMEOUT
    while not any(p.stat().st_size > 0 for p in work.glob(markers)):
        assert proc.poll() is None, f"workflow ended before {markers} had a record:\n" + (
            log.read_text()[-4000:])
        assert time.monotonic() < deadline, f"{markers} had no record (a hang)"
        time.sleep(0.2)   # polling interval only: the condition decides, not the time
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert proc.returncode == -signal.SIGKILL


def _files(root: Path, pattern: str) -> list[Path]:
    return sorted(p.relative_to(root) for p in (root / "results").rglob(pattern))


def test_killed_run_resumes_to_identical_results(ci_run, tmp_path_factory):
    work = copy_repo(tmp_path_factory.mktemp("killed"))
    _kill_when_running(work, work.parent / "killed.log", "results/logs/identify/*.log")
    assert not (work / "results" / "tables" / "identification.csv").exists()
    # what a job killed inside gbpipe.io.atomic_path leaves (hidden, recognisable name)
    planted = work / "results" / "simulate" / ".speed_up_square.nc.x1y2z3.gbpipe.tmp"
    planted.parent.mkdir(parents=True, exist_ok=True)
    planted.write_bytes(b"half a NetCDF file")

    locked = snakemake(work, check=False)
    assert locked.returncode != 0 and "lock" in (locked.stdout + locked.stderr).lower()
    snakemake(work, "--unlock")
    snakemake(work, "--rerun-incomplete")

    assert not planted.exists()
    assert _files(work, "*.tmp") == []
    assert _files(work, "*.nc") == _files(ci_run, "*.nc")
    assert _files(work, "*.csv") == _files(ci_run, "*.csv")
    for rel in _files(ci_run, "*.nc"):
        a, b = io.read(ci_run / rel), io.read(work / rel)
        xr.testing.assert_allclose(a, b, rtol=1e-12, atol=0)
        assert a.attrs["config_sha256"] == b.attrs["config_sha256"]
    for rel in _files(ci_run, "*.csv"):
        assert (work / rel).read_bytes() == (ci_run / rel).read_bytes(), rel
    assert _files(work, "*.png") == _files(ci_run, "*.png")
