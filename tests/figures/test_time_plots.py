"""The min-max envelope that figures 7-10 draw instead of every sample."""

import numpy as np

from gbpipe.figures.time_plots import _envelope


def test_envelope_keeps_every_runs_extremes_at_their_times():
    fs = 5000.0
    t = np.arange(123_457) / fs                    # not a whole number of runs
    rng = np.random.default_rng(3)
    x = np.sin(2 * np.pi * 0.1 * t) + 0.05 * rng.standard_normal(t.size)
    x[70_001] = 4.0                                # one spike: a strided subset drops it
    te, xe = _envelope(t, x, bins=500)
    assert te.size <= 2 * 500 + 500 and np.all(np.diff(te) > 0)
    # each point is a sample of the record, at its own time
    idx = np.round(te * fs).astype(int)
    assert np.array_equal(x[idx], xe)
    # in every run of 246 samples the envelope spans exactly the record's range
    m = t.size // 500
    for k in range(0, 500, 37):
        run = slice(k * m, (k + 1) * m)
        inside = (te >= t[run][0]) & (te <= t[run][-1])
        assert xe[inside].min() == x[run].min() and xe[inside].max() == x[run].max()
    assert xe.max() == 4.0 and x[::t.size // 1000].max() < 1.5


def test_short_records_are_drawn_whole():
    t = np.arange(1500.0)
    x = np.cos(t)
    te, xe = _envelope(t, x, bins=1000)
    assert np.array_equal(te, t) and np.array_equal(xe, x)
