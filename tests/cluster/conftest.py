"""Fixtures of the cluster tests: one real local SLURM per test session, and the SLURM
runs of the tests, all started at once.

The cluster (tests/cluster/slurm_local.py) is installed with apt-get when missing and
started once; its tests are skipped, with the reason shown, only where it cannot be
installed (not root, no apt-get, or apt-get itself failed: its error is the reason).
Any other failure to start it is an error, never a skip. The seconds of the install and
of each start-up step are printed at the end of the session.

A test names the runs it reads with ``@pytest.mark.slurm_runs(name, ...)``; the
``slurm_runs`` fixture starts every run that the selected tests name, at once, before the
first of them: the cluster runs their jobs side by side (most of a run's time is its
Snakemake's start-ups and waits between status queries, not its jobs' work), and each
test waits for its own runs only.
"""

from __future__ import annotations

import pytest
from slurm_local import LocalSlurm, SlurmUnavailable, install
from slurm_runs import MEMORY, RetryRun, SlurmRun

from tests.conftest import STUDY_CONFIGS, study_targets
from tests.workflow.runs import copy_repo, snakemake_env

#: Seconds of the install and of each start-up step, for the session's summary.
TIMINGS: dict[str, float] = {}


@pytest.fixture(scope="session")
def slurm(tmp_path_factory) -> LocalSlurm:
    """A running one-node SLURM (munge, mariadb, slurmdbd, slurmctld, slurmd)."""
    try:
        TIMINGS["install"] = install()
    except SlurmUnavailable as err:
        pytest.skip(f"no local SLURM can be installed here: {err}")
    cluster = LocalSlurm(tmp_path_factory.mktemp("slurm"))
    TIMINGS.update(cluster.start())
    yield cluster
    cluster.stop()


def pytest_configure(config):
    config.addinivalue_line("markers", "slurm_runs(*names): SLURM runs the test reads "
                            "(started together by the slurm_runs fixture)")


def _start(name: str, cluster: LocalSlurm, tmp_path_factory) -> SlurmRun:
    """Start SLURM run ``name`` in a new scratch folder."""
    if name == "ci":   # the CI config, in a fresh copy of the repository
        work = copy_repo(tmp_path_factory.mktemp("slurm_run"))
        return SlurmRun(cluster, work, snakemake_env(work), "--configfile", "config/ci.yaml")
    if name == "study":   # the four-gearbox study's kinematics and model stages
        work = copy_repo(tmp_path_factory.mktemp("slurm_study"))
        return SlurmRun(cluster, work, snakemake_env(work), "--configfile", *STUDY_CONFIGS,
                        "--", *study_targets())
    if name == "no_retries":
        return RetryRun(cluster, tmp_path_factory.mktemp("retry") / "no_retries",
                        "--config", "retries=0")
    if name == "retries":
        return RetryRun(cluster, tmp_path_factory.mktemp("retry") / "retries")
    raise ValueError(f"no SLURM run named {name!r}")


@pytest.fixture(scope="session")
def slurm_runs(request, slurm, tmp_path_factory) -> dict[str, SlurmRun]:
    """Name -> run, for every run the selected tests name (all started here, at once)."""
    names = sorted({n for item in request.session.items
                    for mark in item.iter_markers("slurm_runs") for n in mark.args})
    runs: dict[str, SlurmRun] = {}
    try:
        for name in names:
            runs[name] = _start(name, slurm, tmp_path_factory)
        yield runs
    finally:
        for run in runs.values():
            run.stop()


def pytest_terminal_summary(terminalreporter):
    if TIMINGS:
        steps = ", ".join(f"{k} {v:.1f}" for k, v in TIMINGS.items())
        terminalreporter.write_line(f"local SLURM [s]: {steps}; start-up total "
                                    f"{sum(v for k, v in TIMINGS.items() if k != 'install'):.1f}")
    if MEMORY:
        rules = ", ".join(f"{r} {m:.0f}/{a}" for r, (m, a) in sorted(MEMORY.items()))
        terminalreporter.write_line(f"SLURM peak/asked memory per rule [MB]: {rules}")

