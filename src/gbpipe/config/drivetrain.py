"""Checks of the drivetrain the models are built from, at load.

With a ``drivetrain:`` section, its description (docs/drivetrain.md) is checked element
by element (:func:`gbpipe.model.chain_checks.check_description`: each error names the
key path, e.g. ``drivetrain.gears[1].parent``); without one, the paper's bench generated
from ``gearbox:`` + ``bench:`` is checked the same way, once, so that the models built
later (a fit builds one per evaluation) may skip the checks.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from gbpipe.model.chain import build_chain
from gbpipe.model.drivetrain import gearbox_chain, paper_chain

__all__ = ["check_drivetrain"]


def check_drivetrain(cfg: Mapping[str, Any]) -> None:
    """Build the configured drivetrain (or the paper's) with every check.

    Raises
    ------
    gbpipe.errors.ConfigError
        Naming the element's key path, what is wrong and the fix.
    """
    if cfg.get("drivetrain"):
        build_chain(cfg["drivetrain"], "drivetrain")
    else:
        paper_chain(cfg, check=True)
    gearbox_chain(cfg, check=True)
