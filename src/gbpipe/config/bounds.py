"""What the configured bench itself implies: closed-loop stability and the model order.

Both need the bench's state matrix (:func:`gbpipe.model.bench_ss`, numpy only, a few
milliseconds), so they run at load, after the gearbox checks.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from gbpipe import model
from gbpipe.config.scope import simulated
from gbpipe.units import TWO_PI

__all__ = ["states_in_band", "order_bound", "plant_order", "check_gains"]


def states_in_band(cfg: Mapping[str, Any], closed: bool) -> int:
    """States of the configured bench with ``|λ| <= 2π · identify.frf.f_max``.

    Two states per oscillatory mode below ``f_max``, one per real pole, including the
    rigid-body and controller integrators at or near 0. Modes above ``f_max`` are filtered
    out by the decimation and cannot be identified.

    Parameters
    ----------
    cfg : mapping
        Configuration with checked ``gearbox``, ``bench`` and ``identify.frf.f_max``.
    closed : bool
        The closed-loop bench (with its controller states) or the open-loop plant.

    Returns
    -------
    int
        At least 1.
    """
    ev = np.linalg.eigvals(model.bench_ss(cfg, closed=closed).A)
    in_band = np.abs(ev) <= TWO_PI * float(cfg["identify"]["frf"]["f_max"])
    return max(1, int(np.count_nonzero(in_band)))


def order_bound(cfg: Mapping[str, Any]) -> int:
    """Upper bound of the identified model order: closed-loop bench states in the band.

    The records come from the closed-loop bench (:func:`states_in_band`). For the paper's
    bench every one of its 26 states is in the band (highest mode 339 Hz < 350 Hz); 24 are
    the open-loop plant's.
    """
    return states_in_band(cfg, closed=True)


def plant_order(cfg: Mapping[str, Any]) -> int:
    """The order ``identify.order: model`` stands for: open-loop bench states in the band.

    The mechanics without the controllers, whose integrators the identified pairings open
    or see as inputs (:func:`states_in_band`): 24 for the paper's bench (12 degrees of
    freedom, all below 339 Hz), 20 for the example gearbox (two of its modes lie at
    648 Hz). It follows the gearbox; the singular values of the paper's records rarely
    show this order as a gap (``order: auto`` picks 1 to 4 there), so it is the default.
    """
    return states_in_band(cfg, closed=False)


def check_gains(cfg: Mapping[str, Any]) -> None:
    """Refuse controller gains that make the closed-loop bench unstable.

    Only when the campaign is simulated (:func:`gbpipe.config.scope.simulated`): the
    simulator runs the closed loop from a steady rotation. A bench config's loops ran on
    the bench; its description may have no loop at all (motors without ``controller``,
    a chain whose rigid-body angle nothing holds), which is the plant the fit needs.

    Raises
    ------
    gbpipe.errors.UnstableGain
        From :func:`gbpipe.model.check_stability`, naming the gain to lower.
    """
    if simulated(cfg):
        model.check_stability(cfg)
