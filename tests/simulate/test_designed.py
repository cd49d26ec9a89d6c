"""Designed-excitation tests (``campaign.designed``, issue 14).

The record's set-point minus its base test's is the designed signal, whose spectrum is
checked by an FFT over whole periods (lines k / period inside the band, flat, the
configured rms; no power elsewhere), the PRBS by its levels and bit length; the torque
limit is refused naming the fields; the record does not depend on the list's order.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import gbpipe.simulate as sim
from gbpipe.config import load
from gbpipe.errors import ExcitationError
from tests.conftest import CONFIG

RPM = 2 * np.pi / 60.0  # rad/s per rpm, written out independently of the library
MS = {"name": "ms", "base": "speed_up", "setpoint": "torque", "signal": "multisine",
      "phases": "random", "band": [2.0, 300.0], "rms": 1500.0, "period": 2.0}
PR = {"name": "pr", "base": "speed_up", "setpoint": "speed", "signal": "prbs",
      "band": [0.0, 450.0], "rms": 8.0}
SHORT = {"campaign": {"tests": ["speed_up", "torque_up"], "settle": 2.0, "hold": 3.0,
                      "designed": [MS, PR]},
         "identify": {"tests": ["speed_up", "torque_up", "ms", "pr"]}}


@pytest.fixture(scope="module")
def cfg():
    return load(CONFIG, SHORT)


def test_names_and_base(cfg):
    assert sim.test_names(cfg) == ["speed_up", "torque_up", "ms", "pr"]
    assert sim.base_test(cfg, "ms") == "speed_up"
    assert sim.base_test(cfg, "torque_up") == "torque_up"
    with pytest.raises(ValueError, match=r"^test: unknown test 'nope'.*ms, pr"):
        sim.base_test(cfg, "nope")


def test_multisine_spectrum_on_the_torque_setpoint(cfg):
    ds = sim.test(cfg, "ms", "square", measured_like=False)
    base = sim.test(cfg, "speed_up", "square", measured_like=False)
    x = (ds.torque_ref - base.torque_ref).values
    np.testing.assert_array_equal(ds.speed_ref.values, base.speed_ref.values)
    np.testing.assert_allclose(x, sim.designed_setpoint(cfg, "ms", "square")[1], atol=1e-9)
    fs = cfg["campaign"]["sample_rate"]
    n_per = round(MS["period"] * fs)
    periods = x.size // n_per
    seg = x[: periods * n_per]
    amp = np.abs(np.fft.rfft(seg)) * 2 / seg.size     # cosine amplitudes [N·m]
    f = np.fft.rfftfreq(seg.size, 1 / fs)
    on_grid = np.arange(f.size) % periods == 0         # multiples of 1 / period
    band = on_grid & (f >= MS["band"][0]) & (f <= MS["band"][1])
    lines = amp[band]
    # the lines: every grid frequency of the band, equal amplitudes, the configured rms
    assert band.sum() == round((MS["band"][1] - MS["band"][0]) * MS["period"]) + 1
    np.testing.assert_allclose(lines, lines.mean(), rtol=1e-9)
    assert np.sqrt(np.sum(lines ** 2) / 2) == pytest.approx(MS["rms"], rel=1e-9)
    assert np.sqrt(np.mean(seg ** 2)) == pytest.approx(MS["rms"], rel=1e-9)
    assert amp[~band].max() < 1e-9 * lines.max()       # nothing outside the band


def test_prbs_on_the_speed_setpoint(cfg):
    t, x = sim.designed_setpoint(cfg, "pr", "square")
    _, speed, torque = sim.designed_reference(cfg, "pr", "square")
    _, speed0, torque0 = sim.designed_reference(cfg, "speed_up", "square")
    np.testing.assert_array_equal(torque, torque0)
    np.testing.assert_allclose(speed - speed0, x, rtol=0, atol=1e-12)
    # +-rms [rpm] in rad/s, bits of m = floor(0.3 fs / f_max) = 3 samples: 1667 Hz clock
    np.testing.assert_allclose(np.abs(x), PR["rms"] * RPM, rtol=1e-12)
    edges = np.flatnonzero(np.diff(np.sign(x))) + 1
    assert np.all(np.diff(edges) % 3 == 0)
    assert abs(x.mean()) < 0.01 * PR["rms"] * RPM      # balanced (max-length sequence)


def test_speed_setpoint_beyond_the_motor_limit_is_refused(cfg):
    """The PRBS on the speed set-point drives the driver motor: with the limit just
    above the base test's simulated peak, the designed test is refused naming both keys."""
    base = sim.test(cfg, "speed_up", "square", measured_like=False)
    peak = float(np.abs(base.motor_torque_driver).max())
    tight = load(CONFIG, SHORT, {"bench": {"torque_limit": {"driver": 1.02 * peak}}})
    with pytest.raises(ExcitationError) as err:
        sim.test(tight, "pr", "square")
    msg = str(err.value)
    assert "campaign.designed[1].rms" in msg and "bench.torque_limit.driver" in msg
    assert "factor <=" in msg                          # the scale that would fit


def test_record_independent_of_list_order(cfg):
    a = sim.test(cfg, "pr", "tapered")
    swapped = load(CONFIG, SHORT, {"campaign": {"designed": [PR, MS]}})
    b = sim.test(swapped, "pr", "tapered")
    xr.testing.assert_identical(a, b)
    other = load(CONFIG, SHORT, {"campaign": {"designed": [{**PR, "seed_offset": 1}, MS]}})
    c = sim.designed_setpoint(other, "pr", "tapered")[1]
    assert not np.array_equal(c, sim.designed_setpoint(cfg, "pr", "tapered")[1])
