"""Logging for workflow scripts: one call sends gbpipe's log records to the job's log file."""

from __future__ import annotations

import logging
import sys

__all__ = ["setup_log"]


def setup_log(logfile: str | None = None, name: str = "gbpipe") -> logging.Logger:
    """Log to ``logfile`` (and stderr) at INFO level; return the ``gbpipe`` logger.

    Python warnings (e.g. a joint TSA that stopped at its best pass) go to the same
    handlers, as WARNING records of the ``py.warnings`` logger: the job's log says what
    the numbers rest on. (Through the root logger they could be lost: Snakemake's script
    preamble configures logging of its own.)
    """
    logger = logging.getLogger(name)
    logger.setLevel(logging.INFO)
    fmt = logging.Formatter("%(asctime)s %(levelname)s %(message)s")
    handlers: list[logging.Handler] = [logging.StreamHandler(sys.stderr)]
    if logfile:
        handlers.append(logging.FileHandler(logfile, mode="w"))
    warned = logging.getLogger("py.warnings")
    for lg in (logger, warned):
        lg.handlers.clear()
        for h in handlers:
            lg.addHandler(h)
    warned.propagate = False
    for h in handlers:
        h.setFormatter(fmt)
    logging.captureWarnings(True)
    return logger
