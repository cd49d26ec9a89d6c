"""Shared fixtures: the repository paths, loaded configurations, and the two complete runs
(CI config, bench-record example) that the workflow and cluster tests share.

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


@pytest.fixture(scope="session")
def ci_run(tmp_path_factory) -> Path:
    """A copy of the repository with a complete CI run in ``results/`` (shared by the
    workflow and cluster tests: built once per session)."""
    from tests.workflow.runs import copy_repo, snakemake

    work = copy_repo(tmp_path_factory.mktemp("ci_run"))
    snakemake(work)
    return work


@pytest.fixture(scope="session")
def measured_run(tmp_path_factory) -> tuple[Path, dict]:
    """A copy of the repository whose ``bench/`` holds the example's files (written from a
    simulated test record by ``tests/measured/bench_campaign.py``), with the example's
    complete run in ``results/``; and the truth the files encode (the record)."""
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


@pytest.fixture(scope="session")
def study_run(tmp_path_factory) -> tuple[Path, str]:
    """A copy of the repository with the study's kinematics and model stages run locally
    (``snakemake -j2``; shared by the workflow and cluster tests), and Snakemake's log."""
    from tests.workflow.runs import copy_repo, snakemake

    work = copy_repo(tmp_path_factory.mktemp("study_run"))
    proc = snakemake(work, "--configfile", *STUDY_CONFIGS, "--", *study_targets())
    return work, proc.stdout + proc.stderr
