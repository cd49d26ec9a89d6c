"""Tests of gbpipe.harmonics.cepstrum against hand-built records (:mod:`removal_signals`):
the comb lifter's zeros at the rahmonics computed by hand, known lines in white noise at
constant speed and on a known sweep."""

from __future__ import annotations

import numpy as np
import pytest
from harmonic_sweeps import line_power
from removal_signals import FAMILIES, constant_speed, db, inner, sweep

from gbpipe.harmonics.cepstrum import comb_lifter, residual_cepstrum


def test_comb_lifter_zeros_the_rahmonics():
    # cycle 1.5 orders at 12 quefrency samples per rev: rahmonics every 8 samples
    lift = comb_lifter(64, 12.0, [1.5], 1)
    zeros = {q + d for q in (8, 16, 24, 32) for d in (-1, 0, 1)}
    zeros |= {64 - q for q in zeros}
    expected = np.array([0.0 if i in zeros else 1.0 for i in range(64)])
    np.testing.assert_array_equal(lift, expected)


@pytest.fixture(scope="module")
def steady():
    c = constant_speed(rpm=600.0, duration=30.0)
    rng = np.random.default_rng(5)
    c["n"] = 0.05 * rng.standard_normal(c["t"].size)
    c["h"] = (np.cos(c["theta"] + 0.3) + 0.5 * np.cos(2 * c["theta"] + 1.0)
              + 0.8 * np.cos(3 * c["theta"] - 1.0))
    return c


def test_lines_brought_down_to_the_floor_and_the_rest_untouched(steady):
    c = steady
    r = residual_cepstrum(c["h"] + c["n"], c["fs"], c["pulses"], {"shaft": [1.0, 2.0, 3.0]},
                          frame_revs=32)
    m = inner(c["t"], c["pulses"], 2.0)
    err = r - c["n"]
    assert db(line_power(c["h"], c["theta"], [1, 2, 3], m),
              line_power(err, c["theta"], [1, 2, 3], m)) >= 30.0
    # more than 0.2 orders (2 Hz) from the lines the removal changes nothing
    win = np.hanning(m.sum())
    f = np.fft.rfftfreq(m.sum(), 1 / c["fs"])
    far = np.all(np.abs(f[:, None] - c["f_rot"] * np.array([1, 2, 3])) > 2.0, axis=1)
    e_far = np.abs(np.fft.rfft(err[m] * win)[far]) ** 2
    n_far = np.abs(np.fft.rfft(c["n"][m] * win)[far]) ** 2
    assert db(e_far.sum(), n_far.sum()) <= -50.0


def test_families_on_a_sweep():
    sw = sweep(noise=0.05)
    r = residual_cepstrum(sw["x"], sw["fs"], sw["pulses"], FAMILIES, frame_revs=16)
    m = inner(sw["t"], sw["pulses"], 1.0)
    err = r - sw["res"]
    for orders in FAMILIES.values():
        assert db(line_power(sw["h"], sw["theta"], orders, m),
                  line_power(err, sw["theta"], orders, m)) >= 20.0


def test_record_shorter_than_a_frame(steady):
    c = steady
    with pytest.raises(ValueError, match="frame_revs"):
        residual_cepstrum(c["h"], c["fs"], c["pulses"], {"shaft": [1.0]}, frame_revs=1000)
