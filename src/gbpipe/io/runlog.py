"""Logging for workflow scripts: one call sends gbpipe's log records to the job's log file."""

from __future__ import annotations

import logging
import sys

__all__ = ["setup_log"]


def setup_log(logfile: str | None = None, name: str = "gbpipe") -> logging.Logger:
    """Log to ``logfile`` (and stderr) at INFO level; return the ``gbpipe`` logger."""
    logger = logging.getLogger(name)
    logger.setLevel(logging.INFO)
    logger.handlers.clear()
    fmt = logging.Formatter("%(asctime)s %(levelname)s %(message)s")
    handlers: list[logging.Handler] = [logging.StreamHandler(sys.stderr)]
    if logfile:
        handlers.append(logging.FileHandler(logfile, mode="w"))
    for h in handlers:
        h.setFormatter(fmt)
        logger.addHandler(h)
    logging.captureWarnings(True)
    return logger
