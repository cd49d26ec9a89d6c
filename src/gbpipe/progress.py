"""Progress of a long loop in a job's log: a line at most every :data:`EVERY` seconds.

A stage that works through an hour-long record for minutes says where it is, so that a
person reading the job's log (or Snakemake's output) sees it alive and how far it got::

    progress = Progress(log, "TSA of 8 signals", total=8)
    for k, x in enumerate(signals, 1):
        ...
        progress(k)          # logs "TSA of 8 signals: 3/8 (38 %), 21 s, about 35 s left"

Nothing is logged before :data:`EVERY` seconds have passed since the start or the last
line, so a short job's log stays as it was; the check costs a clock read per step.
"""

from __future__ import annotations

import logging
import time

__all__ = ["EVERY", "Progress"]

#: Longest time between two progress lines [s] (issue 47: a stage over 10 s logs at
#: least every 10 s; a line a little early leaves room for a step's own length).
EVERY = 8.0


class Progress:
    """Log ``what`` with the steps done at most every ``every`` seconds.

    Parameters
    ----------
    logger : logging.Logger
        The stage's logger (its records reach the job's log, :func:`gbpipe.io.setup_log`).
    what : str
        What the loop does, for the reader ("Welch spectra of 4 pairings").
    total : int, optional
        Number of steps, for the share done and the time left.
    every : float
        Longest time between two lines [s].
    """

    def __init__(self, logger: logging.Logger, what: str, total: int | None = None,
                 every: float = EVERY) -> None:
        self.logger, self.what, self.total, self.every = logger, what, total, every
        self.start = self.last = time.monotonic()

    def __call__(self, done: int, detail: str = "") -> None:
        """Report ``done`` steps finished (and ``detail``) if :attr:`every` has passed."""
        now = time.monotonic()
        if now - self.last < self.every:
            return
        self.last = now
        elapsed = now - self.start
        if self.total:
            left = elapsed * (self.total - done) / max(done, 1)
            where = (f"{done}/{self.total} ({100.0 * done / self.total:.0f} %), "
                     f"{elapsed:.0f} s, about {left:.0f} s left")
        else:
            where = f"{done} done, {elapsed:.0f} s"
        self.logger.info("%s: %s%s", self.what, where, f"; {detail}" if detail else "")
