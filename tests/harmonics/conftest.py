"""Fixtures of the harmonic-removal tests: the synthetic sweeps of :mod:`harmonic_sweeps`,
built once per session (every test reads them, none changes them)."""

from __future__ import annotations

import pytest
from harmonic_sweeps import make_sweep


@pytest.fixture(scope="session")
def sw():
    """The synthetic sweep with its broadband noise."""
    return make_sweep()


@pytest.fixture(scope="session")
def clean():
    """The same sweep without noise."""
    return make_sweep(noise=0.0)
