"""Tests of gbpipe.io.setup_log: a job's log holds gbpipe's records and Python warnings."""

from __future__ import annotations

import subprocess
import sys


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
