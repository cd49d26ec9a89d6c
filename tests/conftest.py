"""Shared fixtures: the repository paths, loaded configurations, and the complete runs
(CI config, bench-record example, four-gearbox study) that the workflow and cluster tests
share.

The shared runs are built in the background from the end of collection on (`SharedRuns`),
one after the other, for those the selected tests use: their Snakemake jobs go on beside
the tests that run first, and a test waits for its run's end (never for a time).

The suite runs on pytest-xdist workers (``-n auto --dist loadgroup`` in pyproject.toml):
every test that reads a shared run or the local SLURM is in one group (`RUNS_GROUP`), which
one worker runs first, so that each run is built, and the cluster started, once; the other
tests go to the workers one by one, except that those sharing a module- or conftest-level
fixture share a worker (`xdist_group`), so that the fixture is built once. ``-n 0`` runs
the whole suite in one process as before.

Imports sit in the fixtures: the thread settings below must precede numpy's import."""

from __future__ import annotations

import fcntl
import os
import subprocess
import tempfile
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")
# The local SLURM starts in a thread of its own (tests/cluster/conftest.py) and spawns its
# daemons while the other threads work. CPython spawns with vfork on Linux, whose child
# shares the parent's memory until its exec: once (29 November) the exec of `slurmd -C`
# failed with EFAULT ("Bad address") there. fork gives the child its own copy.
if hasattr(subprocess, "_USE_VFORK"):
    subprocess._USE_VFORK = False

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config" / "config.yaml"
CI_CONFIG = ROOT / "config" / "ci.yaml"
EXAMPLE = ROOT / "config" / "examples" / "gearbox_1planetary_2parallel.yaml"


@contextmanager
def apt_lock() -> Iterator[None]:
    """Held around every apt-get of the session: the cluster tests' SLURM install runs in
    a background thread (tests/cluster/conftest.py) beside the tests, and two apt-get at
    once fail on dpkg's lock. A file lock: it holds across threads and xdist workers."""
    with open(Path(tempfile.gettempdir()) / "gbpipe-tests-apt.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


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
        try:
            for name, done in self._done.items():
                try:
                    self._results[name] = (True, BUILDERS[name](self._tmp))
                except BaseException as err:   # raised in the test that needs the run
                    self._results[name] = (False, err)
                done.set()
        finally:
            BUILDS_ENDED.set()

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

#: Set when this process's background builds of the shared runs have ended, or when
#: collection ends and it starts none: tests/cluster/conftest.py starts the SLURM runs
#: after it (their jobs would take the cores from the builds every other test of
#: `RUNS_GROUP` waits for).
BUILDS_ENDED = threading.Event()


#: The xdist group of every test that reads a shared run or the local SLURM.
RUNS_GROUP = "shared runs and SLURM"


def _in_cluster(item: pytest.Item) -> bool:
    return Path(item.path).resolve().is_relative_to(ROOT / "tests" / "cluster")


def reads_a_run(item: pytest.Item) -> bool:
    """Whether the test reads a shared run (`BUILDERS`) or the local SLURM."""
    return _in_cluster(item) or any(n in item.fixturenames for n in BUILDERS)


def distributed(config: pytest.Config) -> bool:
    """Whether the session runs on pytest-xdist workers grouped by `xdist_group` (a
    worker's own ``dist`` is "no"; xdist marks it with ``loadgroup``)."""
    option = config.option
    return getattr(option, "dist", "no") == "loadgroup" or getattr(option, "loadgroup", False)


def xdist_group(item: pytest.Item) -> str | None:
    """The test's xdist group: `RUNS_GROUP`; else the home (module, or folder of a
    conftest.py) of the widest module- or session-scoped fixture it uses, so that such a
    fixture is built by one worker only; else none (the test may go to any worker).

    The fixtures of this conftest.py (configurations: cheap, built by every worker) and of
    plugins (``tmp_path_factory``) do not count."""
    if reads_a_run(item):
        return RUNS_GROUP
    own = Path(__file__).parent.relative_to(ROOT).as_posix()
    # pytest has no public map from a test to its fixtures' definitions
    homes = [defs[-1].baseid for defs in item._fixtureinfo.name2fixturedefs.values()
             if defs[-1].scope != "function" and defs[-1].baseid not in ("", own)]
    return min(homes, key=len) if homes else None


def pytest_configure(config):
    # pytest-xdist groups (--dist loadgroup) by writing each test's `_nodeid`, a slot that
    # pytest 9.2 no longer has: every worker would then build the runs and start a cluster
    if distributed(config) and not hasattr(pytest.Item, "_nodeid"):
        raise pytest.UsageError(
            f"pytest {pytest.__version__} and pytest-xdist do not group tests together "
            "(--dist loadgroup); install requirements-test.txt's versions (pytest<9.2), "
            "or run the suite in one process with -n 0")


def pytest_itemcollected(item):
    group = xdist_group(item) if distributed(item.config) else None
    if group is not None:   # before xdist's own hook, which reads the mark
        item.add_marker(pytest.mark.xdist_group(group))


def _order(item: pytest.Item) -> tuple[bool, bool, bool]:
    # under xdist, the tests that read a run first: their group is then the first unit of
    # work, sent to a worker at once, which starts the runs' builds and the cluster at once
    first = not (distributed(item.config) and reads_a_run(item))
    # the cluster tests last (their SLURM runs, started in the background by
    # tests/cluster/conftest.py, go on beside every other test), and before them, the tests
    # that read a shared run after those that do not (its build goes on beside them)
    return first, _in_cluster(item), any(n in item.fixturenames for n in BUILDERS)


@pytest.hookimpl(trylast=True)   # after the deselection (-k, -m) of the other plugins
def pytest_collection_modifyitems(session, config, items):
    items.sort(key=_order)   # stable: every other order is kept


def tests_will_run(session: pytest.Session) -> bool:
    """Whether the collected tests will run (not ``--collect-only``, no collection error
    that ends the session): only then are runs started in the background."""
    option = session.config.option
    return not option.collectonly and (session.testsfailed == 0
                                       or option.continue_on_collection_errors)


#: Background starts that wait for this worker's first test of `RUNS_GROUP`.
_DEFERRED: list[Callable[[], None]] = []


def start_in_background(session: pytest.Session, start: Callable[[], None]) -> None:
    """Call ``start`` (which starts work in a background thread) now, or under xdist when
    this worker sets up its first test of `RUNS_GROUP`: only that worker needs the runs."""
    if distributed(session.config):
        _DEFERRED.append(start)
    else:
        start()


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    if _DEFERRED and reads_a_run(item):
        while _DEFERRED:
            _DEFERRED.pop(0)()


def pytest_collection_finish(session):
    names = [n for n in BUILDERS if any(n in item.fixturenames for item in session.items)]
    if names and tests_will_run(session):
        factory = session_tmp_path_factory(session)
        start_in_background(session, lambda: _SHARED.append(SharedRuns(names, factory)))
    else:
        BUILDS_ENDED.set()


#: Summary lines the xdist workers sent (`summary_lines` of tests/cluster/conftest.py),
#: printed by the controller, which never loads that conftest.py (it collects nothing).
_WORKER_LINES: list[str] = []


@pytest.hookimpl(optionalhook=True)   # an xdist hook, called in the controller
def pytest_testnodedown(node, error):
    _WORKER_LINES.extend(getattr(node, "workeroutput", {}).get("summary_lines", []))


def pytest_terminal_summary(terminalreporter):
    for line in _WORKER_LINES:
        terminalreporter.write_line(line)


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
