"""Fixtures of the simulation tests."""

from __future__ import annotations

import pytest


@pytest.fixture
def no_simulation(monkeypatch):
    """Any call of the simulator fails the test: errors must come before simulating."""
    def boom(*args, **kwargs):
        raise AssertionError("lsim was called: the error must come before simulating")

    monkeypatch.setattr("gbpipe.simulate.campaign.lsim", boom)
