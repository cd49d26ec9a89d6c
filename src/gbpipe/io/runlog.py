"""Logging for workflow scripts: one call sends gbpipe's log records to the job's log file."""

from __future__ import annotations

import atexit
import logging
import os
import re
import resource
import sys
from pathlib import Path

from gbpipe.io.heartbeat import Heartbeat

__all__ = ["PEAK_LINE", "job_resources", "setup_log"]

#: The last line of every job log: the job's own peak resident memory [MB] and CPU time
#: [s] (kernel accounting of the script process, read when it exits; not a sampler's, so
#: a short job is measured as well as a long one).
PEAK_LINE = "job resources: peak memory {rss_mb:.1f} MB, CPU {cpu_s:.2f} s"


_PEAK_RE = re.compile(re.escape(PEAK_LINE).replace(r"\{rss_mb:\.1f\}", r"([0-9.]+)")
                      .replace(r"\{cpu_s:\.2f\}", r"([0-9.]+)"))


def job_resources(logfile: str | os.PathLike) -> tuple[float, float] | None:
    """The peak memory [MB] and CPU time [s] a job logged (:data:`PEAK_LINE`), or None
    when its log has no such line (the job was killed, or never set up its log)."""
    found = _PEAK_RE.findall(Path(logfile).read_text(errors="replace"))
    return (float(found[-1][0]), float(found[-1][1])) if found else None


def _peak_rss_mb() -> float:
    """Peak resident memory of this process [MB].

    Linux's ``VmHWM`` belongs to the process image, so it starts afresh at ``exec``.
    ``ru_maxrss`` does not: it keeps what the forking parent had resident (a Snakemake
    job's script would report Snakemake's ~250 MB), so it is only the fallback where
    ``/proc`` is missing.
    """
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return float(line.split()[1]) * 1024 / 1e6      # kB
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e6


def _log_resources(logger: logging.Logger) -> None:
    """Log :data:`PEAK_LINE` for this process (runs at interpreter exit)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    logger.info(PEAK_LINE.format(rss_mb=_peak_rss_mb(), cpu_s=usage.ru_utime + usage.ru_stime))


def setup_log(logfile: str | None = None, name: str = "gbpipe") -> logging.Logger:
    """Log to ``logfile`` (and stderr) at INFO level; return the ``gbpipe`` logger.

    Python warnings (e.g. a joint TSA that stopped at its best pass) go to the same
    handlers, as WARNING records of the ``py.warnings`` logger: the job's log says what
    the numbers rest on. (Through the root logger they could be lost: Snakemake's script
    preamble configures logging of its own.) With a ``logfile``, the job's peak memory
    and CPU time (:data:`PEAK_LINE`) are logged when the process exits.
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
    if logfile:
        # registered after logging's own exit handler, so it runs before the files close
        atexit.register(_log_resources, logger)
        # the log's first line marks the job's start (its imports done); from then on a
        # line at least every few seconds: the stage's own, or the heartbeat's saying
        # where the job is (a long step on an hour-long record)
        beat = Heartbeat(logger)
        for lg in (logger, warned):
            lg.addHandler(beat)
        logger.info("job started: %s", Path(logfile).stem)
        beat.start()
    return logger
