"""What a configuration runs: a simulated campaign, or bench records (``measured:``).

One definition, read by every check of the simulated campaign and by the workflow's
targets: a campaign is simulated exactly when no bench record is mapped. A config with
``measured:`` records runs the records and nothing is simulated, so the campaign's
settings (controllers and ripple of the motors, noise, set-point profiles, the data
versions only a simulation has) are neither needed nor checked there: a bench config asks
only for what the bench has.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["simulated", "BENCH_VERSIONS"]

#: Data versions a bench record can have: ``raw``, and ``tsa`` with a tacho channel on the
#: paper's gearbox (``clean`` and the removal methods beyond TSA need the simulator's
#: exact separation).
BENCH_VERSIONS = ("raw", "tsa")


def simulated(cfg: Mapping[str, Any]) -> bool:
    """True when the configuration simulates its campaign (no ``measured:`` record).

    Parameters
    ----------
    cfg : mapping
        A configuration after the schema (``measured`` present, ``{}`` by default).
    """
    return not cfg["measured"]
