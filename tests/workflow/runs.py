"""Scratch copies of the repository and Snakemake runs in them (the workflow and cluster
tests; the shared runs are the session fixtures ``ci_run``, ``measured_run`` and
``study_run`` of tests/conftest.py, built once per session in the background).

Every workflow test runs Snakemake in a copy (what a fresh clone holds), with that copy's
``src`` first on ``PYTHONPATH``, under the usual umask 022. Tests that change files change
their own copy.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

#: The repository (a fresh clone's content is copied from here).
ROOT = Path(__file__).resolve().parents[2]

SNAKEMAKE = [sys.executable, "-m", "snakemake", "--cores", "2", "--configfile",
             "config/ci.yaml"]
#: The usual umask of a run (set by subprocess itself: a ``preexec_fn`` is unsafe while
#: other threads run, as the background builds of tests/conftest.py do).
UMASK = 0o022
#: Not part of a fresh clone: results, Snakemake's state, caches.
_SKIP = {"results", ".snakemake", ".git", "__pycache__", ".pytest_cache", ".ruff_cache"}


def copy_repo(dest: Path) -> Path:
    """Copy the tracked and untracked-but-not-ignored files: a fresh clone's content.

    Outside a git checkout (a source archive), every file but results and caches.
    """
    proc = subprocess.run(["git", "ls-files", "-co", "--exclude-standard", "-z"], cwd=ROOT,
                          capture_output=True)
    if proc.returncode == 0:
        files = [f for f in proc.stdout.decode().split("\0") if f]
    else:
        files = [str(p.relative_to(ROOT)) for p in ROOT.rglob("*")
                 if p.is_file() and not _SKIP & set(p.relative_to(ROOT).parts)]
    for f in files:
        src = ROOT / f
        if src.is_file():
            (dest / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / f, follow_symlinks=False)
    return dest


def snakemake_env(work: Path) -> dict[str, str]:
    """Environment of a Snakemake run in ``work``: its own ``src`` first, one thread."""
    env = dict(os.environ, OMP_NUM_THREADS="1", MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(work / "src"),
                                                      env.get("PYTHONPATH")]))
    return env


def snakemake(work: Path, *args: str, check: bool = True) -> subprocess.CompletedProcess:
    """Run Snakemake (CI config, 2 cores) in ``work``; fail with its log tail if it fails."""
    proc = subprocess.run([*SNAKEMAKE, *args], cwd=work, capture_output=True, text=True,
                          env=snakemake_env(work), umask=UMASK)
    if check and proc.returncode != 0:
        raise AssertionError(f"snakemake {' '.join(args)} failed:\n{proc.stderr[-6000:]}")
    return proc


def start_snakemake(work: Path, log: Path) -> subprocess.Popen:
    """Start the CI workflow in ``work`` in its own process group (so it can be killed)."""
    with open(log, "w") as fh:
        return subprocess.Popen([*SNAKEMAKE], cwd=work, stdout=fh, stderr=subprocess.STDOUT,
                                env=snakemake_env(work), start_new_session=True,
                                umask=UMASK)


#: The bench-record example on top of the CI config (config/examples/measured.yaml).
MEASURED_CONFIGS = ("config/ci.yaml", "config/examples/measured.yaml")
