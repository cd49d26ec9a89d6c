"""Measured-like noise against physics and independent computations (issue 14).

* the converter pulsating torque appears at harmonic x pole_pairs x shaft frequency with
  the amplitude the bench's own frequency response gives (sampled system, evaluated on the
  unit circle, not simulated), fitted by least squares at the known frequency;
* encoder quantisation: the speed error has the variance ``q**2 / (6 dt**2)`` and the
  lag-one correlation -1/2 of a differenced white uniform quantisation error;
* tachometer jitter: its std is recovered from the pulse-time residuals;
* the seed draws all of it: same config, identical record.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from scipy.signal import cont2discrete

import gbpipe.simulate as sim
from gbpipe.config import load
from gbpipe.model import bench_ss
from gbpipe.simulate.noise import quantisation_noise
from gbpipe.simulate.tacho import pulse_times
from tests.conftest import CONFIG

# no designed tests: then only ramp tests can be identified
SHORT = {"campaign": {"settle": 2.0, "hold": 1.0, "designed": []},
         "identify": {"tests": ["speed_up", "speed_down", "torque_up", "torque_down"]}}
STILL = {"broadband": 0.0, "pole_pairs": 2, "pulsating": []}
#: every sensor noise off (and the gear excitation, by random_only): measured - clean is
#: then the encoder's part
QUIET = {"noise": {"sensor": {"speed": 0.0, "torque": 0.0}}}


def _fit_lines(t: np.ndarray, y: np.ndarray, freqs: list[float],
               ) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares complex amplitudes ``a`` of ``y = c0 + c1 t + sum Re(a e^{j 2 pi f
    t})`` (the line takes the slow settling of the speed loop) and the residual."""
    cols = [np.ones_like(t), t - t.mean()]
    for f in freqs:
        cols += [np.cos(2 * np.pi * f * t), -np.sin(2 * np.pi * f * t)]
    X = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return coef[2::2] + 1j * coef[3::2], y - X @ coef


def _sampled_gain(cfg, inp: str, out: str, f: float, dt: float) -> float:
    """|G(e^{j 2 pi f dt})| of the zero-order-hold sampled bench from ``inp`` to ``out``."""
    ss = bench_ss(cfg).select([inp], [out])
    a, b, c, d, _ = cont2discrete((ss.A, ss.B, ss.C, ss.D), dt, method="zoh")
    z = np.exp(2j * np.pi * f * dt)
    return float(abs((c @ np.linalg.solve(z * np.eye(a.shape[0]) - a, b) + d)[0, 0]))


def test_pulsating_torque_line_at_electrical_multiples():
    """Driver motor: 6th and 12th electrical harmonic, 2 pole pairs -> HSS orders 12, 24."""
    lines = [{"harmonic": 6, "amplitude": 100.0}, {"harmonic": 12, "amplitude": 40.0}]
    ripple = {"driver": {"broadband": 150.0, "pole_pairs": 2, "pulsating": lines},
              "driven": STILL}
    cfg = load(CONFIG, SHORT, {"noise": {"motor_ripple": ripple}})
    off = load(CONFIG, SHORT, {"noise": {"motor_ripple": {
        "driver": {**ripple["driver"], "pulsating": []}, "driven": STILL}}})
    a = sim.test(cfg, "torque_up", "square", measured_like=False)
    b = sim.test(off, "torque_up", "square", measured_like=False)
    # same seed, same broadband draws: the difference is the pulsating part alone
    t = a.time.values
    stretch = (t > 0.2) & (t < cfg["campaign"]["settle"])   # constant speed and torque
    shaft_hz = cfg["campaign"]["nominal"]["speed_rpm"] / 60.0
    freqs = [6 * 2 * shaft_hz, 12 * 2 * shaft_hz]          # 224 Hz and 448 Hz
    dt = float(t[1] - t[0])
    for out in ("motor_torque_driver", "torque_meter_driving", "speed_gb2_hss"):
        diff = (a[out] - b[out]).values[stretch]
        fit, _ = _fit_lines(t[stretch], diff, freqs)
        expected = [ln["amplitude"] * _sampled_gain(cfg, "disturbance_driver", out, f, dt)
                    for ln, f in zip(lines, freqs, strict=True)]
        np.testing.assert_allclose(np.abs(fit), expected, rtol=0.01, err_msg=out)
    # the driver motor's torque holds the two lines and nothing else (bar the speed loop's
    # slow settling, which the fit's trend takes)
    diff = (a.motor_torque_driver - b.motor_torque_driver).values[stretch]
    _, resid = _fit_lines(t[stretch], diff, freqs)
    assert np.std(resid) < 0.01 * lines[0]["amplitude"]


def test_quantisation_noise_is_differenced_uniform_error():
    """A speed swept over many counts per sample spreads the fraction of the counts moved
    per sample evenly: e = Q(theta) - theta is white uniform (variance q^2/12), and
    (e[k] - e[k-1]) / dt has variance 2 q^2 / 12 / dt^2 = q^2 / (6 dt^2), lag-one
    correlation -1/2."""
    dt, counts = 2e-4, 4096
    q = 2 * np.pi / counts
    t = np.arange(50_000) * dt
    omega = 100.0 + 3.0 * t                 # 13.0 -> 17.0 counts per sample
    theta = 100.0 * t + 1.5 * t ** 2
    err = quantisation_noise(theta, omega[0], dt, counts)
    assert err.var() == pytest.approx(q ** 2 / (6 * dt ** 2), rel=0.03)
    assert np.corrcoef(err[1:], err[:-1])[0, 1] == pytest.approx(-0.5, abs=0.02)
    # the error integrates to e[k] - e[-1]: the angle stays within one count
    assert np.abs(np.cumsum(err) * dt).max() < q


@pytest.mark.parametrize("frac", [0.1, 0.25, 0.5])
def test_quantisation_at_constant_count_rate(frac):
    """r = 15 + frac counts per sample: the difference of counts is 15 or 16, so the error
    (in q / dt) is -frac or 1 - frac with probabilities 1 - frac and frac (a Bernoulli
    pattern): variance frac (1 - frac) q^2 / dt^2, whose mean over frac is q^2 / 6."""
    dt, counts = 2e-4, 4096
    q = 2 * np.pi / counts
    rate = (15 + frac) * q                     # rad per sample
    theta = 0.3 * q + rate * np.arange(20_000)
    err = quantisation_noise(theta, rate / dt, dt, counts) * dt / q
    assert set(np.round(err, 9)) <= {round(-frac, 9), round(1 - frac, 9)}
    assert err.var() == pytest.approx(frac * (1 - frac), rel=1e-3)


def test_record_speeds_carry_the_encoder_quantisation():
    """Gear excitation and sensor noise off: measured - clean speed is the quantisation
    error of the configured encoder (default 2^23 counts/rev), for the HSS (angle output)
    and the LSS (integral of its speed): the angle error stays within one count, and on
    the HSS the motor ripple spreads the fraction so the q^2 / (6 dt^2) law holds."""
    cfg = sim.random_only(load(CONFIG, SHORT, QUIET))
    ds = sim.test(cfg, "speed_up", "square")
    dt = 1.0 / cfg["campaign"]["sample_rate"]
    q = 2 * np.pi / cfg["noise"]["encoder"]["counts_per_rev"]
    for name in ("speed_gb1_hss", "speed_gb2_hss", "speed_lss"):
        err = (ds[f"{name}_measured"] - ds[name]).values
        assert np.abs(np.cumsum(err) * dt).max() <= q * (1 + 1e-6), name
        assert 0.5 < err.var() / (q ** 2 / (6 * dt ** 2)) < 1.5, name
    for name in ("speed_gb1_hss", "speed_gb2_hss"):
        err = (ds[f"{name}_measured"] - ds[name]).values
        assert err.var() == pytest.approx(q ** 2 / (6 * dt ** 2), rel=0.1), name
    for name in ("motor_torque_driver", "torque_meter_driven"):   # torques: no encoder
        assert np.abs((ds[f"{name}_measured"] - ds[name]).values).max() < 1e-6, name


@pytest.mark.parametrize("clock_hz", [None, 1e7])
def test_tacho_jitter_std_recovered(clock_hz):
    """Constant speed, 60 pulses/rev: residuals against the exact pulse times have the
    std of the jitter (and the clock's floor adds -tick/2 mean, tick^2/12 variance)."""
    omega, ppr, sigma = 117.0, 60, 5e-7
    t = np.arange(0, 10.0, 2e-4)
    times = pulse_times(t, omega * t, ppr, speed=np.full(t.size, omega), clock_hz=clock_hz,
                        rng=3, jitter_s=sigma)
    exact = np.arange(1, times.size + 1) * 2 * np.pi / ppr / omega
    resid = times - exact
    tick = 0.0 if clock_hz is None else 1.0 / clock_hz
    assert resid.mean() == pytest.approx(-tick / 2, abs=3 * sigma / np.sqrt(times.size))
    assert resid.std() == pytest.approx(np.sqrt(sigma ** 2 + tick ** 2 / 12), rel=0.05)


def test_jitter_needs_a_generator():
    t = np.arange(0, 1.0, 1e-3)
    with pytest.raises(ValueError, match="jitter_s > 0: pass rng"):
        pulse_times(t, 100.0 * t, 1, jitter_s=1e-6)


def test_same_config_identical_record():
    cfg = load(CONFIG, SHORT)
    a = sim.test(cfg, "speed_down", "square")
    xr.testing.assert_identical(a, sim.test(cfg, "speed_down", "square"))
    other = sim.test(load(CONFIG, SHORT, {"seed": cfg["seed"] + 1}), "speed_down", "square")
    # the seed draws ripple, sensor noise and jitter: all differ
    for name in ("motor_torque_driven", "speed_gb1_hss_measured", "pulse_time"):
        assert not np.array_equal(a[name].values, other[name].values), name
