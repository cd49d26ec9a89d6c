"""A run killed with SIGKILL, then resumed as the README says, gives the results of an
uninterrupted run, and leaves no temporaries behind.

The run is as small as the claim needs: a copy of the complete CI run (``ci_run``, its
files' times and Snakemake's records kept) without one record's identification (its
``identify`` outputs and log; a record no fit reads) and the identification table, so that
``snakemake`` plans that record's identify job and what depends on it. Once the job is
working (its log holds its first record) the whole process group (Snakemake and its jobs)
gets SIGKILL: no handler runs, the lock and any half-written temporary stay. One more
temporary, as a job killed while writing leaves it, is planted so the clean-up is always
exercised. Then the README's recovery: ``snakemake --unlock``, then
``snakemake --rerun-incomplete``. Every NetCDF output must equal the uninterrupted run's,
every CSV table byte for byte.
"""

from __future__ import annotations

import os
import shutil
import signal
import time
from pathlib import Path

import xarray as xr

from gbpipe import io
from tests.workflow.runs import snakemake, start_snakemake

#: Seconds to wait for the job to start: only a hang gets near it (the whole CI run takes
#: under a minute on 2 idle cores).
_START_TIMEOUT = 1800.0


def _identification_of_one_record(run: Path) -> tuple[str, list[Path]]:
    """What the copy of the complete run loses: one record's identification results and
    its log (its log holding a record is the sign that the new run's job is working), and
    the identification table; and the log's path relative to ``run``.

    The record is one that no physical fit reads (no ``fit/<record>.nc``) where there is
    one: the resumed run then redoes that identification, the table and the figure, not
    also the fit and its figure (about 22 s of CPU); what is killed and resumed is the
    same."""
    logs = sorted((run / "results" / "logs" / "identify").glob("*.log"))
    log = min(logs, key=lambda p: (run / "results" / "fit" / f"{p.stem}.nc").exists())
    files = [*(run / "results" / "identify").glob(f"{log.stem}_*.nc"), log,
             run / "results" / "tables" / "identification.csv"]
    return str(log.relative_to(run)), files


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


def test_killed_run_resumes_to_identical_results(ci_run, tmp_path):
    work = shutil.copytree(ci_run, tmp_path / "killed", symlinks=True)
    marker, removed = _identification_of_one_record(work)
    assert len(removed) >= 3   # a file per method, the log and the table
    for path in removed:
        path.unlink()
    _kill_when_running(work, tmp_path / "killed.log", marker)
    assert not (work / "results" / "tables" / "identification.csv").exists()
    # what a job killed inside gbpipe.io.atomic_path leaves (hidden, recognisable name)
    planted = work / "results" / "simulate" / ".speed_up_square.nc.x1y2z3.gbpipe.tmp"
    planted.parent.mkdir(parents=True, exist_ok=True)
    planted.write_bytes(b"half a NetCDF file")

    locked = snakemake(work, check=False)
    assert locked.returncode != 0 and "lock" in (locked.stdout + locked.stderr).lower()
    snakemake(work, "--unlock")
    snakemake(work, "--rerun-incomplete")
    # the resumed run made the identification again (not left the copy as it was)
    assert all(p.exists() for p in removed)

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
