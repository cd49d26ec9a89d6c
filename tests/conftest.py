"""Shared fixtures: the repository paths and loaded configurations."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config" / "config.yaml"
CI_CONFIG = ROOT / "config" / "ci.yaml"
EXAMPLE = ROOT / "config" / "examples" / "gearbox_1planetary_2parallel.yaml"


@pytest.fixture(scope="session")
def cfg():
    from gbpipe.config import load

    return load(CONFIG)


@pytest.fixture(scope="session")
def cfg_example():
    from gbpipe.config import load

    return load(CONFIG, EXAMPLE)
