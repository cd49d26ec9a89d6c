"""Tests of gbpipe.harmonics.crossings and the regression's modal envelope: a line swept
through a lightly damped mode (its response computed by python-control's / scipy's
``lsim`` of the mode's second-order transfer function, not by the carrier's recursion),
beside the same mode's response to white noise.

The bound the removal is held to (docs/removal.md, "Crossings"): a least-squares fit
takes, of a broadband part, about its spectral density at the order per real parameter,
so an envelope of ``2 / knot_spacing`` real parameters per second, swept at ``df/dt``
through a band it crosses entirely, takes a fraction ``1 / (knot_spacing * B)`` of the
band's power (``B`` the band width in Hz), whatever the sweep rate; the modal carrier
adds two parameters over the record. Few of those parameters sit at the resonance peak,
where the band's power is, so one noise realisation scatters by about half the mean:
the bound is held on the mean of three, with a factor 2.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from gbpipe.harmonics import crossing_marks, half_power_band, residual_regression
from gbpipe.harmonics.crossings import modal_carriers

FS = 1000.0  # Hz
MODE = (62.2, 0.02)  # Hz, damping ratio: the bench's 62 Hz mode
ORDER = 3.0
F0, RATE = 18.0, 0.25  # shaft rate at t = 0 [rev/s] and its slope [rev/s^2]: 15 rpm/s
PRE, T_END = 3.0, 24.0  # s simulated before the record (the mode's transient), record [s]
HALF = 4.0  # Hz: half width of the mode band read


def _record(seed: int) -> dict:
    t = np.arange(-PRE * FS, T_END * FS) / FS
    theta = 2 * np.pi * (F0 * t + 0.5 * RATE * t**2)
    wn, z = 2 * np.pi * MODE[0], MODE[1]
    sdof = signal.lti([wn**2], [1.0, 2 * z * wn, wn**2])
    # the line: the mode's swept response to the order's excitation, plus a direct term
    _, line, _ = signal.lsim(sdof, np.cos(ORDER * theta + 0.4), t + PRE)
    line = line + 0.2 * np.sin(ORDER * theta)
    _, noise, _ = signal.lsim(sdof, np.random.default_rng(seed).standard_normal(t.size),
                              t + PRE)
    keep = t >= 0
    t, theta = t[keep], theta[keep]
    k = np.arange(1, int(theta[-1] / (2 * np.pi)) + 1)
    # the pulse times of whole revolutions: the roots of theta(t) = 2 pi k
    pulses = (-F0 + np.sqrt(F0**2 + 2 * RATE * k)) / RATE
    # the broadband part 30 dB below the line in the mode band
    return {"t": t, "h": line[keep], "n": 0.3 * noise[keep], "pulses": pulses}


def _band_power(x: np.ndarray, t: np.ndarray) -> float:
    """Power within HALF Hz of the mode over the samples where the order is within it."""
    sel = np.abs(ORDER * (F0 + RATE * t) - MODE[0]) <= HALF
    f, p = signal.periodogram(x[sel], FS, window="hann")
    return float(p[np.abs(f - MODE[0]) <= HALF].sum())


@pytest.fixture(scope="module")
def crossings():
    return [_record(seed) for seed in (1, 2, 3)]


def _remove(x, rec, **kw):
    return residual_regression(x, FS, rec["pulses"], {"shaft": [ORDER]},
                               knot_spacing=KNOTS, **kw)


KNOTS = 2.0  # s


def test_modal_envelope_keeps_the_mode_band_within_the_parameter_bound(crossings):
    modes = [MODE]
    rec = crossings[0]
    t = rec["t"]
    # the fit is linear: its error on the harmonic part alone is what it leaves of it
    left = _remove(rec["h"], rec, modes=modes)
    assert 10 * np.log10(_band_power(rec["h"], t) / _band_power(left, t)) >= 60.0
    taken, after, before = [], [], []
    for rec in crossings:
        n, t = rec["n"], rec["t"]
        taken.append(_band_power(n - _remove(n, rec, modes=modes), t) / _band_power(n, t))
        after.append(_band_power(_remove(rec["h"] + n, rec, modes=modes), t))
        before.append(_band_power(n, t))
    bound = 2 / (KNOTS * 2 * HALF)  # twice the envelope's share 1 / (knot_spacing B)
    assert np.mean(taken) <= bound
    # the level a band reading shows, over the three records: within the 1 dB,
    # and a loss (the line's leftover is 60 dB down, no gain is left)
    change = 10 * np.log10(np.sum(after) / np.sum(before))
    assert -1.0 <= change <= 0.0


def test_a_slow_envelope_alone_cannot_follow_the_ring_up(crossings):
    # the same knots without the modal carrier: the line rings with the mode on its time
    # constant 1 / (zeta w_n) = 0.13 s, far faster than 2 s knots follow
    rec = crossings[0]
    left = _remove(rec["h"], rec)
    t = rec["t"]
    assert 10 * np.log10(_band_power(rec["h"], t) / _band_power(left, t)) < 40.0
    # a family left out of modal_families is fitted by its envelope alone
    np.testing.assert_allclose(_remove(rec["h"], rec, modes=[MODE], modal_families=[]),
                               left, rtol=0, atol=1e-9 * np.max(np.abs(rec["h"])))


def test_modes_are_checked(crossings):
    rec = crossings[0]
    with pytest.raises(ValueError, match="damping ratio"):
        _remove(rec["h"], rec, modes=[(62.2, 1.5)])
    with pytest.raises(ValueError, match="mode_reach"):
        _remove(rec["h"], rec, modes=[MODE], mode_reach=0.0)


def test_crossing_marks_match_a_dense_scan_of_each_bin():
    rng = np.random.default_rng(5)
    orders = np.array([1.0, 2.0, 3.0, 5.357])
    modes = np.column_stack([rng.uniform(20, 130, 6), rng.uniform(0.01, 0.06, 6)])
    edges = np.linspace(400.0, 1500.0, 23)
    marks = crossing_marks(orders, edges[:-1], edges[1:], modes)
    band = half_power_band(modes)
    for i in range(edges.size - 1):  # independent: order frequencies on a dense rpm grid
        f = np.linspace(edges[i], edges[i + 1], 4001)[:, None] / 60.0 * orders[None, :]
        for j, (lo, hi) in enumerate(band):
            inside = ((f >= lo) & (f <= hi)).any(axis=0)
            np.testing.assert_array_equal(marks[i, :, j], inside)
    np.testing.assert_allclose(band[:, 1] - band[:, 0], 2 * modes[:, 0] * modes[:, 1])


def test_carriers_of_pairs_that_share_an_order_are_each_their_own():
    # an order near two modes drives both with one phasor (computed once): every pair's
    # carrier must equal the carrier of that pair alone, block by block
    fs = 1000.0
    t = np.arange(20000) / fs
    theta = 2 * np.pi * (F0 * t + 0.5 * RATE * t**2)
    orders = np.array([ORDER, 2 * ORDER])
    modes = np.array([MODE, (70.0, 0.03)])
    pairs = [(0, 0), (0, 1), (1, 1), (1, 0)]
    cuts = np.array([0, 4096, 8192, 15000, t.size])
    together = np.vstack(list(modal_carriers(theta, fs, orders, modes, pairs, cuts)))
    for c, pair in enumerate(pairs):
        alone = np.vstack(list(modal_carriers(theta, fs, orders, modes, [pair], cuts)))
        np.testing.assert_array_equal(together[:, c], alone[:, 0])
