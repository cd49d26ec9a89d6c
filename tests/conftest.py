"""Shared fixtures: the repository paths, loaded configurations, and the complete runs
(CI config, bench-record example, four-gearbox study) that the workflow and cluster tests
share.

The shared runs are built in the background from the end of collection on (`SharedRuns`),
one after the other, for those the selected tests use: their Snakemake jobs go on beside
the tests that run first (mostly one core's work), and a test waits for its run's end
(never for a time).

Imports sit in the fixtures: the thread settings below must precede numpy's import."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config" / "config.yaml"
CI_CONFIG = ROOT / "config" / "ci.yaml"
EXAMPLE = ROOT / "config" / "examples" / "gearbox_1planetary_2parallel.yaml"
#: Held around every apt-get of the session: the cluster tests' SLURM install runs in a
#: background thread (tests/cluster/conftest.py) beside the tests, and two apt-get at once
#: fail on dpkg's lock.
APT_LOCK = threading.Lock()


@pytest.fixture(scope="session")
def cfg():
    from gbpipe.config import load

    return load(CONFIG)


@pytest.fixture(scope="session")
def cfg_example():
    from gbpipe.config import load

    return load(CONFIG, EXAMPLE)


def _build_ci_run(tmp_path_factory) -> Path:
    from tests.workflow.runs import copy_repo, snakemake

    work = copy_repo(tmp_path_factory.mktemp("ci_run"))
    snakemake(work)
    return work


def _build_measured_run(tmp_path_factory) -> tuple[Path, dict]:
    from gbpipe.config import load
    from gbpipe.simulate import test as simulate_test
    from tests.measured.bench_campaign import write_campaign_files
    from tests.workflow.runs import MEASURED_CONFIGS, copy_repo, snakemake

    work = copy_repo(tmp_path_factory.mktemp("measured_run"))
    cfg = load(CONFIG, *(ROOT / c for c in MEASURED_CONFIGS))
    record = simulate_test(cfg, "speed_up", "square", measured_like=True)
    truth = write_campaign_files(record, work / "bench")
    snakemake(work, "--configfile", *MEASURED_CONFIGS)
    return work, {"record": record, "signals": truth, "cfg": cfg}


#: The study of config/examples/study.yaml on top of the CI config: four gearboxes and
#: benches; its tests ask for the kinematics and model stages of each run.
STUDY_CONFIGS = ("config/ci.yaml", "config/examples/study.yaml")
STUDY_RUNS = ("nominal", "planetary_parallel", "soft_coupling", "stiff_housing")


def study_targets() -> list[str]:
    """Per run: Table 2, the three model datasets and figures 3-5 (rule names)."""
    return [t for name in STUDY_RUNS
            for t in (f"results/{name}/tables/table2.csv", f"{name}_figures_model")]


def _build_study_run(tmp_path_factory) -> tuple[Path, str]:
    from tests.workflow.runs import copy_repo, snakemake

    work = copy_repo(tmp_path_factory.mktemp("study_run"))
    proc = snakemake(work, "--configfile", *STUDY_CONFIGS, "--", *study_targets())
    return work, proc.stdout + proc.stderr


#: Shared run fixture -> its builder, in the order they are built in the background.
BUILDERS = {"ci_run": _build_ci_run, "measured_run": _build_measured_run,
            "study_run": _build_study_run}


def session_tmp_path_factory(session: pytest.Session) -> pytest.TempPathFactory:
    """pytest's own ``tmp_path_factory`` (the fixture is not available to a hook): folders
    made from a hook are kept like every test's, for a look after a failure.

    Its base folder is made here, in the main thread, before any background thread uses
    the factory: pytest makes it lazily and without a lock, so a thread and a test asking
    for it at once make two (``pytest-N`` and ``pytest-N+1``), and ``mktemp`` then fails
    with "is not a normalized and relative path" (seen in CI)."""
    factory = session.config._tmp_path_factory
    factory.getbasetemp()
    return factory


class SharedRuns:
    """Builds the shared runs ``names`` (keys of `BUILDERS`) one after the other in a
    thread (each is a ``snakemake --cores 2``: one at a time leaves the tests a core);
    `result` waits for one and gives it, or raises the error its build raised."""

    def __init__(self, names: list[str], tmp_path_factory: pytest.TempPathFactory):
        self._tmp = tmp_path_factory
        self._done = {name: threading.Event() for name in names}
        self._results: dict[str, tuple[bool, object]] = {}
        threading.Thread(target=self._build_all, name="shared runs", daemon=True).start()

    def _build_all(self) -> None:
        for name, done in self._done.items():
            try:
                self._results[name] = (True, BUILDERS[name](self._tmp))
            except BaseException as err:   # raised in the test that needs the run
                self._results[name] = (False, err)
            done.set()

    def __contains__(self, name: str) -> bool:
        return name in self._done

    def result(self, name: str):
        """The run ``name`` once built (its build's error, raised, if it failed)."""
        self._done[name].wait()
        ok, value = self._results[name]
        if not ok:
            raise value
        return value

    def wait_all(self) -> None:
        """Wait until no build is running (the session's end)."""
        for done in self._done.values():
            done.wait()


#: The session's background builds (set when collection ends).
_SHARED: list[SharedRuns] = []


def _order(item: pytest.Item) -> tuple[bool, bool]:
    # the cluster tests last (their SLURM runs, started in the background by
    # tests/cluster/conftest.py, go on beside every other test), and before them, the tests
    # that read a shared run after those that do not (its build goes on beside them)
    cluster = Path(item.path).resolve().is_relative_to(ROOT / "tests" / "cluster")
    return cluster, any(n in item.fixturenames for n in BUILDERS)


@pytest.hookimpl(trylast=True)   # after the deselection (-k, -m) of the other plugins
def pytest_collection_modifyitems(session, config, items):
    items.sort(key=_order)   # stable: every other order is kept


def tests_will_run(session: pytest.Session) -> bool:
    """Whether the collected tests will run (not ``--collect-only``, no collection error
    that ends the session): only then are runs started in the background."""
    option = session.config.option
    return not option.collectonly and (session.testsfailed == 0
                                       or option.continue_on_collection_errors)


def pytest_collection_finish(session):
    names = [n for n in BUILDERS if any(n in item.fixturenames for item in session.items)]
    if names and tests_will_run(session):
        _SHARED.append(SharedRuns(names, session_tmp_path_factory(session)))


def pytest_sessionfinish(session):
    # a build still running (the session ended early) is waited for, so that no Snakemake
    # is left running in pytest's folders after the session
    while _SHARED:
        _SHARED.pop().wait_all()


def _shared(name: str, tmp_path_factory):
    if _SHARED and name in _SHARED[0]:
        return _SHARED[0].result(name)
    return BUILDERS[name](tmp_path_factory)   # asked for outside the collected tests


@pytest.fixture(scope="session")
def ci_run(tmp_path_factory) -> Path:
    """A copy of the repository with a complete CI run in ``results/`` (shared by the
    workflow and cluster tests: built once per session, in the background)."""
    return _shared("ci_run", tmp_path_factory)


@pytest.fixture(scope="session")
def measured_run(tmp_path_factory) -> tuple[Path, dict]:
    """A copy of the repository whose ``bench/`` holds the example's files (written from a
    simulated test record by ``tests/measured/bench_campaign.py``), with the example's
    complete run in ``results/``; and the truth the files encode (the record)."""
    return _shared("measured_run", tmp_path_factory)


@pytest.fixture(scope="session")
def study_run(tmp_path_factory) -> tuple[Path, str]:
    """A copy of the repository with the study's kinematics and model stages run locally
    (``snakemake -j2``; shared by the workflow and cluster tests), and Snakemake's log."""
    return _shared("study_run", tmp_path_factory)
