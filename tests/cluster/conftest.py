"""Fixtures of the cluster tests: one real local SLURM per test session.

The cluster (tests/cluster/slurm_local.py) is installed with apt-get when missing and
started once; its tests are skipped, with the reason shown, only where it cannot be
installed (not root, no apt-get, or apt-get itself failed: its error is the reason).
Any other failure to start it is an error, never a skip. The seconds of the install and
of each start-up step are printed at the end of the session.
"""

from __future__ import annotations

import pytest
from slurm_local import LocalSlurm, SlurmUnavailable, install
from slurm_runs import MEMORY

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


def pytest_terminal_summary(terminalreporter):
    if TIMINGS:
        steps = ", ".join(f"{k} {v:.1f}" for k, v in TIMINGS.items())
        terminalreporter.write_line(f"local SLURM [s]: {steps}; start-up total "
                                    f"{sum(v for k, v in TIMINGS.items() if k != 'install'):.1f}")
    if MEMORY:
        rules = ", ".join(f"{r} {m:.0f}/{a}" for r, (m, a) in sorted(MEMORY.items()))
        terminalreporter.write_line(f"SLURM peak/asked memory per rule [MB]: {rules}")

