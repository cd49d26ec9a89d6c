"""Fixtures of the cluster tests: one real local SLURM per test session, and the SLURM
runs of the tests, all started in the background as soon as the session is collected
(under pytest-xdist: by the worker that runs them, when it sets up the first of them; see
tests/conftest.py).

The cluster (tests/cluster/slurm_local.py) is installed with apt-get when missing and
started once; its tests are skipped, with the reason shown, only where it cannot be
installed (not root, no apt-get, or apt-get itself failed: its error is the reason).
Any other failure to start it is an error, never a skip. The seconds of the install and
of each start-up step are printed at the end of the session.

A test names the runs it reads with ``@pytest.mark.slurm_runs(name, ...)``. Once
collection ends, a background thread installs and starts the cluster and then, once the
shared runs of tests/conftest.py are built (`BUILDS_ENDED`: the tests of their group wait
for those builds, and the cluster tests come last), starts every run that the selected
tests name, at once: the cluster runs their jobs side by side
(most of a run's time is its Snakemake's start-ups and waits between status queries, not
its jobs' work), while the rest of the suite goes on, which the cluster tests therefore
follow (tests/conftest.py moves them to the end of the session). The ``slurm`` and
``slurm_runs`` fixtures wait for that thread (its end, never a time), and each test waits
for its own runs only. The runs and the cluster are stopped when the session ends.
"""

from __future__ import annotations

import threading

import pytest
from slurm_local import LocalSlurm, SlurmUnavailable, install
from slurm_runs import MEMORY, RetryRun, SlurmRun

from tests.conftest import (
    BUILDS_ENDED,
    STUDY_CONFIGS,
    apt_lock,
    session_tmp_path_factory,
    start_in_background,
    study_targets,
    tests_will_run,
)
from tests.workflow.runs import copy_repo, snakemake_env

#: Seconds of the install and of each start-up step, for the session's summary.
TIMINGS: dict[str, float] = {}


class Background:
    """The cluster's install and start-up, then the start of the runs ``names``, in a
    thread; `cluster` and `runs` once it ended (`wait`), or the error that stopped it."""

    def __init__(self, names: list[str], tmp_path_factory: pytest.TempPathFactory):
        self.names, self.tmp = names, tmp_path_factory
        self.cluster: LocalSlurm | None = None
        self.runs: dict[str, SlurmRun] = {}
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._start, name="local SLURM", daemon=True)
        self._thread.start()

    def _start(self) -> None:
        try:
            with apt_lock():
                TIMINGS["install"] = install()
            self.cluster = LocalSlurm(self.tmp.mktemp("slurm"))
            TIMINGS.update(self.cluster.start())
            # the runs' jobs start once the shared runs are built: every test of their
            # group waits for those builds, and the cluster tests come last
            BUILDS_ENDED.wait()
            for name in self.names:
                self.runs[name] = _start(name, self.cluster, self.tmp)
        except BaseException as err:   # reported by the fixtures, in the test that needs it
            self.error = err

    def wait(self) -> None:
        """Wait for the thread's end (install, start-up and the runs' start)."""
        self._thread.join()

    def stop(self) -> None:
        """Stop the runs that still run and the cluster (once the thread ended)."""
        self.wait()
        for run in self.runs.values():
            run.stop()
        if self.cluster is not None:
            self.cluster.stop()


#: The session's background start, if a selected test reads a SLURM run.
_BACKGROUND: list[Background] = []


def pytest_collection_finish(session):
    names = sorted({n for item in session.items
                    for mark in item.iter_markers("slurm_runs") for n in mark.args})
    if names and tests_will_run(session):
        factory = session_tmp_path_factory(session)
        start_in_background(session, lambda: _BACKGROUND.append(Background(names, factory)))


def pytest_sessionfinish(session):
    while _BACKGROUND:
        _BACKGROUND.pop().stop()
    if hasattr(session.config, "workeroutput"):   # an xdist worker: to the controller
        session.config.workeroutput["summary_lines"] = summary_lines()


def _background() -> Background:
    if not _BACKGROUND:
        raise RuntimeError("no SLURM was started for this session: the test does not name "
                           "its runs with @pytest.mark.slurm_runs")
    background = _BACKGROUND[0]
    background.wait()
    if isinstance(background.error, SlurmUnavailable):
        pytest.skip(f"no local SLURM can be installed here: {background.error}")
    if background.error is not None:
        raise background.error
    return background


@pytest.fixture(scope="session")
def slurm() -> LocalSlurm:
    """A running one-node SLURM (munge, mariadb, slurmdbd, slurmctld, slurmd)."""
    return _background().cluster


def pytest_configure(config):
    config.addinivalue_line("markers", "slurm_runs(*names): SLURM runs the test reads "
                            "(started together in the background when collection ends)")


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
def slurm_runs(slurm) -> dict[str, SlurmRun]:
    """Name -> run, for every run the selected tests name (all started at once, in the
    background, when collection ended)."""
    return _background().runs


def summary_lines() -> list[str]:
    """The session summary's lines: the cluster's start-up seconds, each rule's memory."""
    lines = []
    if TIMINGS:
        steps = ", ".join(f"{k} {v:.1f}" for k, v in TIMINGS.items())
        lines.append(f"local SLURM [s]: {steps}; start-up total "
                     f"{sum(v for k, v in TIMINGS.items() if k != 'install'):.1f}")
    if MEMORY:
        rules = ", ".join(f"{r} {m:.0f}/{a}" for r, (m, a) in sorted(MEMORY.items()))
        lines.append(f"SLURM peak/asked memory per rule [MB]: {rules}")
    return lines


def pytest_terminal_summary(terminalreporter):
    for line in summary_lines():   # one process (-n 0); under xdist, see tests/conftest.py
        terminalreporter.write_line(line)
