"""Tests of gbpipe.io.setup_log: a job's log holds gbpipe's records and Python warnings."""

from __future__ import annotations

import logging
import subprocess
import sys
import time

from gbpipe.io.heartbeat import Heartbeat


def test_warnings_reach_the_job_log_even_when_root_has_a_handler(tmp_path):
    # a fresh interpreter, as a Snakemake job is; the root logger already has a handler
    # (as a script preamble may set one up), which would swallow the warning otherwise
    log = tmp_path / "job.log"
    code = (
        "import logging, warnings\n"
        "logging.getLogger().addHandler(logging.NullHandler())\n"
        "from gbpipe.io import setup_log\n"
        f"lg = setup_log({str(log)!r})\n"
        "lg.info('stage started')\n"
        "warnings.warn('joint TSA stopped at pass 4', UserWarning)\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    text = log.read_text()
    # the first line marks the job's start (a reader sees it alive before its first news)
    assert text.splitlines()[0].endswith("INFO job started: job")
    assert "INFO stage started" in text
    assert "WARNING" in text and "joint TSA stopped at pass 4" in text
    assert "joint TSA stopped at pass 4" in run.stderr  # and on the job's stderr


def test_the_heartbeat_says_where_a_silent_job_is(caplog):
    # a job silent for 1 s with a 0.3 s heartbeat: lines naming the busy function, about
    # every 0.3 s; none once the job logs again
    log = logging.getLogger("gbpipe.test_heartbeat")
    beat = Heartbeat(log, every=0.3)
    log.addHandler(beat)

    def busy_fitting_step():
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            sum(range(1000))

    with caplog.at_level(logging.INFO, logger="gbpipe.test_heartbeat"):
        beat.start()
        busy_fitting_step()
        log.info("step done")
        n = len(caplog.records)
        time.sleep(0.1)
    beats = [r.getMessage() for r in caplog.records if "still working" in r.getMessage()]
    assert 2 <= len(beats) <= 4
    assert all(m.startswith("still working: busy_fitting_step (") for m in beats)
    assert len(caplog.records) == n       # the job's own line reset the silence
    log.removeHandler(beat)
