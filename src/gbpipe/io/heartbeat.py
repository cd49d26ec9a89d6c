"""A job's heartbeat: a log line saying where the job is when it has said nothing for a while.

A stage on an hour-long record runs for minutes; its loops report their progress
(:class:`gbpipe.progress.Progress`), but one long step (a decimation, a factorisation, a
figure) says nothing until it ends. :class:`Heartbeat` is a logging handler that notes
when the job's last line was written, and a daemon thread that, once :data:`EVERY`
seconds have passed without a line, logs the function the main thread is in (the
innermost frame in gbpipe, else the innermost)::

    still working: condition (gbpipe/identify/prepare.py:159), 8 s since the last line

so that a person watching the log (or Snakemake's output) never waits more than about
``EVERY`` seconds for news (more only while the main thread holds the interpreter lock in
one long C call). The thread wakes four times a second and costs nothing measurable.
"""

from __future__ import annotations

import logging
import sys
import threading
import time
from pathlib import Path

from gbpipe.progress import EVERY

__all__ = ["Heartbeat"]


class Heartbeat(logging.Handler):
    """Handler that notes every record's time; :meth:`start` runs the watching thread.

    Parameters
    ----------
    logger : logging.Logger
        Where the heartbeat lines go (the job's logger, to which this handler is added).
    every : float
        Longest silence [s] before a heartbeat line.
    """

    def __init__(self, logger: logging.Logger, every: float = EVERY) -> None:
        super().__init__(logging.DEBUG)
        self.logger, self.every = logger, every
        self.last = time.monotonic()
        self.main = threading.main_thread().ident

    def emit(self, record: logging.LogRecord) -> None:
        self.last = time.monotonic()

    def start(self) -> None:
        """Start the daemon thread (it ends with the process)."""
        threading.Thread(target=self._watch, name="gbpipe-heartbeat", daemon=True).start()

    def where(self) -> str:
        """The main thread's function and place: the innermost frame in gbpipe, else the
        innermost one."""
        frame = sys._current_frames().get(self.main)
        inner, ours = frame, None
        while frame is not None and ours is None:
            parts = Path(frame.f_code.co_filename).parts
            if "gbpipe" in parts:
                ours = frame
            frame = frame.f_back
        frame = ours or inner
        if frame is None:
            return "(main thread gone)"
        parts = Path(frame.f_code.co_filename).parts
        short = "/".join(parts[parts.index("gbpipe"):] if "gbpipe" in parts else parts[-1:])
        return f"{frame.f_code.co_name} ({short}:{frame.f_lineno})"

    def _watch(self) -> None:
        while True:
            time.sleep(min(0.25, self.every / 4))
            silent = time.monotonic() - self.last
            if silent >= self.every:
                self.logger.info("still working: %s, %.0f s since the last line",
                                 self.where(), silent)
