"""What the configured bench itself implies: closed-loop stability and the model order.

Both need the bench's state matrix (:func:`gbpipe.model.bench_ss`, numpy only, a few
milliseconds), so they run at load, after the gearbox checks.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from gbpipe import model
from gbpipe.units import TWO_PI

__all__ = ["order_bound", "check_gains"]


def order_bound(cfg: Mapping[str, Any]) -> int:
    """Upper bound of the identified model order: states of the bench in the band.

    The records come from the closed-loop bench; a state is in the band when its
    eigenvalue ``λ`` has ``|λ| <= 2π · identify.frf.f_max`` (two states per oscillatory
    mode below ``f_max``, one per real pole, including the rigid-body and controller
    integrators at or near 0). Modes above ``f_max`` are filtered out by the decimation
    and cannot be identified. For the paper's bench every one of its 26 states is in the
    band (highest mode 339 Hz < 350 Hz); 24 are the open-loop plant's.

    Parameters
    ----------
    cfg : mapping
        Configuration with checked ``gearbox``, ``bench`` and ``identify.frf.f_max``.

    Returns
    -------
    int
        At least 1.
    """
    ev = np.linalg.eigvals(model.bench_ss(cfg).A)
    in_band = np.abs(ev) <= TWO_PI * float(cfg["identify"]["frf"]["f_max"])
    return max(1, int(np.count_nonzero(in_band)))


def check_gains(cfg: Mapping[str, Any]) -> None:
    """Refuse controller gains that make the closed-loop bench unstable.

    Raises
    ------
    gbpipe.errors.UnstableGain
        From :func:`gbpipe.model.check_stability`, naming the gain to lower.
    """
    model.check_stability(cfg)
