"""The pass of a backfitting that changed its residual least, and when the passes since
have diverged.

Both backfittings of gbpipe iterate smoothers whose gain can exceed 1, so their passes
may contract the residual for a while and then grow it geometrically: the joint TSA's
sliding and quadratic averages (:mod:`gbpipe.harmonics.joint`) and the Vold-Kalman
filter's order updates near a record's ends (:mod:`gbpipe.harmonics.vkf`). Each keeps the
output of the pass that changed least and, once the change has stayed above it long
enough, stops and returns that output; each sets how long and how far above.
"""

from __future__ import annotations

import numpy as np

__all__ = ["LeastChange"]


class LeastChange:
    """The least change of a backfitting's passes, and whether the run has diverged.

    Parameters
    ----------
    patience : int
        Passes after the least one before the run can be judged diverging.
    factor : float
        How many times the least the change must then be, at least (1: any pass that is
        not a new least). A converging iteration's change can rise for many passes in a
        row (a non-normal iteration's transient), so a factor above 1 keeps it running.
    """

    def __init__(self, patience: int, factor: float = 1.0) -> None:
        self.patience, self.factor = int(patience), float(factor)
        self.least, self.at = np.inf, 0

    def update(self, change: float, done: int) -> bool:
        """Record the change of pass ``done``; True if it is the least so far (the caller
        keeps that pass's output)."""
        if change < self.least:
            self.least, self.at = change, done
            return True
        return False

    def diverged(self, change: float, done: int) -> bool:
        """True once ``patience`` passes have followed the least and pass ``done``'s
        change is ``factor`` times the least or more."""
        return done - self.at >= self.patience and change >= self.factor * self.least
