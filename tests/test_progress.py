"""Tests of gbpipe.progress: a long loop's progress lines, at most every EVERY seconds."""

from __future__ import annotations

import logging

import pytest

from gbpipe import progress as progress_module
from gbpipe.progress import EVERY, Progress


class Clock:
    """A monotonic clock the test moves by hand [s]."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def clock(monkeypatch):
    c = Clock()
    monkeypatch.setattr(progress_module.time, "monotonic", c)
    return c


def test_a_line_at_most_every_interval_with_share_and_time_left(clock, caplog):
    log = logging.getLogger("gbpipe.test_progress")
    p = Progress(log, "TSA of 8 signals", total=8, every=10.0)
    with caplog.at_level(logging.INFO, logger="gbpipe.test_progress"):
        clock.now += 4.0
        p(1)                      # 4 s after the start: too early
        clock.now += 7.0
        p(2, "speed_load")        # 11 s: a line; 2 of 8 in 11 s -> 33 s left
        clock.now += 9.0
        p(3)                      # 9 s after the last line: too early
        clock.now += 1.0
        p(4)                      # 10 s after it: a line; 4 of 8 in 21 s -> 21 s left
    lines = [r.getMessage() for r in caplog.records]
    assert lines == ["TSA of 8 signals: 2/8 (25 %), 11 s, about 33 s left; speed_load",
                     "TSA of 8 signals: 4/8 (50 %), 21 s, about 21 s left"]


def test_without_a_total_the_steps_and_the_time(clock, caplog):
    log = logging.getLogger("gbpipe.test_progress")
    p = Progress(log, "passes")
    with caplog.at_level(logging.INFO, logger="gbpipe.test_progress"):
        clock.now += EVERY
        p(5)
    assert [r.getMessage() for r in caplog.records] == [f"passes: 5 done, {EVERY:.0f} s"]


def test_a_short_loop_logs_nothing(clock, caplog):
    log = logging.getLogger("gbpipe.test_progress")
    p = Progress(log, "short", total=1000)
    with caplog.at_level(logging.INFO, logger="gbpipe.test_progress"):
        for k in range(1000):
            clock.now += 0.9 * EVERY / 1000
            p(k + 1)
    assert caplog.records == []
