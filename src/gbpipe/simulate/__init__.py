"""Simulation: the exact LTI simulator, the test campaigns and the speed sweep.

Public API: :func:`lsim`, :func:`test`, :func:`sweep` (imported lazily: the simulator
pulls in python-control, which config validation does not need).
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

__all__ = ["lsim", "test", "sweep"]

_WHERE = {"lsim": "gbpipe.simulate.lsim", "test": "gbpipe.simulate.campaign",
          "sweep": "gbpipe.simulate.campaign", "steady_state": "gbpipe.simulate.campaign"}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'gbpipe.simulate' has no attribute {name!r}")
