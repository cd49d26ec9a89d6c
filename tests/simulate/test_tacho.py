"""Tests for gbpipe.simulate.tacho against analytic pulse times."""

from __future__ import annotations

import numpy as np
import pytest

from gbpipe.simulate.tacho import analog_channel, pulse_times, tooth_errors

PPR = 60


def _ramp(fs: float, duration: float, w0: float, alpha: float):
    t = np.arange(int(round(duration * fs)) + 1) / fs
    return t, w0 * t + 0.5 * alpha * t**2, w0 + alpha * t


def _ramp_inverse(theta: np.ndarray, w0: float, alpha: float) -> np.ndarray:
    # t = (-w0 + sqrt(w0^2 + 2 alpha theta)) / alpha, written without cancellation
    return 2 * theta / (w0 + np.sqrt(w0**2 + 2 * alpha * theta))


@pytest.mark.parametrize("with_speed", [True, False])
def test_constant_speed_exact(with_speed):
    f = 23.7  # rev/s
    t = np.arange(0, 2.0 + 1e-12, 1e-3)
    angle = 2 * np.pi * f * t
    speed = np.full_like(t, 2 * np.pi * f) if with_speed else None
    p = pulse_times(t, angle, PPR, speed=speed)
    n_exp = int(np.floor(f * t[-1] * PPR))
    assert p.size == n_exp
    np.testing.assert_allclose(p, np.arange(1, n_exp + 1) / (PPR * f), rtol=0, atol=1e-9)


@pytest.mark.parametrize("with_speed", [True, False])
def test_linear_ramp_matches_analytic_inverse(with_speed):
    # Coarse sampling (several pulses per sample) so interpolation does the work.
    w0, alpha = 2 * np.pi * 5.0, 2 * np.pi * 20.0
    t, angle, speed = _ramp(fs=200.0, duration=3.0, w0=w0, alpha=alpha)
    p = pulse_times(t, angle, PPR, speed=speed if with_speed else None)
    k = np.arange(1, p.size + 1)
    expected = _ramp_inverse(2 * np.pi * k / PPR, w0, alpha)
    assert p.size == int(np.floor(angle[-1] / (2 * np.pi) * PPR))
    np.testing.assert_allclose(p, expected, rtol=1e-9)


def test_smooth_speed_fluctuation_against_root_finding():
    """Non-polynomial angle: compare with pulse times from root-finding on the exact θ(t)."""
    w0, amp, om = 2 * np.pi * 10.0, 0.3, 2 * np.pi * 3.0  # amp*om < w0: monotone

    def theta(x):
        return w0 * x + amp * np.sin(om * x)

    def dtheta(x):
        return w0 + amp * om * np.cos(om * x)

    fs = 2000.0
    t = np.arange(0, 1.0 + 1e-12, 1 / fs)
    p = pulse_times(t, theta(t), PPR, speed=dtheta(t))
    target = 2 * np.pi * np.arange(1, p.size + 1) / PPR
    ref = target / w0
    for _ in range(50):  # Newton on the exact function
        ref = ref - (theta(ref) - target) / dtheta(ref)
    # Hermite error ~ h^4 |θ''''| / 384 / ω: far below 1e-3 of the sample interval
    assert np.max(np.abs(p - ref)) < 1e-3 / fs
    p_fd = pulse_times(t, theta(t), PPR)  # finite-difference slopes, still accurate
    assert np.max(np.abs(p_fd - ref)) < 1e-2 / fs


def test_count_and_start_angle():
    """Count is floor(revolutions * ppr) from angle 0; a tooth exactly at the start is skipped."""
    t = np.linspace(0, 1, 101)
    for revs in (0.01, 1.0, 3.49, 7.999):
        p = pulse_times(t, 2 * np.pi * revs * t, 8)
        assert p.size == int(np.floor(revs * 8 + 1e-12))
    # Start mid-way: teeth in (angle[0], angle[-1]] only
    ang = 2 * np.pi * (1.3 + 2.0 * t)  # 1.3 -> 3.3 rev, ppr 4: teeth 6..13 (1.5 .. 3.25 rev)
    p = pulse_times(t, ang, 4)
    np.testing.assert_allclose(p, ((np.arange(6, 14) / 4) - 1.3) / 2.0, atol=1e-12)


def test_clock_quantisation_floors():
    f = 17.3
    t = np.arange(0, 1.0, 1e-3)
    exact = pulse_times(t, 2 * np.pi * f * t, PPR)
    clock = 1e5
    q = pulse_times(t, 2 * np.pi * f * t, PPR, clock_hz=clock)
    ticks = q * clock
    np.testing.assert_allclose(ticks, np.round(ticks), atol=1e-6)  # on the counter grid
    assert np.all(q <= exact + 1e-12)  # never later than the true edge
    assert np.all(exact - q < 1 / clock)  # within one tick
    assert np.mean(exact - q) > 0.25 / clock  # really quantised (mean lag ~ half a tick)


def _expected_with_errors(eps: np.ndarray, w: float, t_end: float):
    """Constant speed w from angle 0: tooth k at 2 pi k / ppr + eps[k mod ppr] -> θ_k / w."""
    ppr = eps.size
    k = np.arange(-1, int(w * t_end / (2 * np.pi) * ppr) + 3)
    th = 2 * np.pi * k / ppr + eps[k % ppr]
    keep = (th > 0) & (th <= w * t_end)
    return k[keep], th[keep] / w


def test_spacing_error_shifts_pulse_by_error_over_speed():
    f = 12.0
    w = 2 * np.pi * f
    t = np.arange(0, 1.0 + 1e-12, 1e-3)
    rng = np.random.default_rng(3)
    eps = rng.uniform(-0.4, 0.4, PPR) * (2 * np.pi / PPR)
    eps[0] = 0.3 * (2 * np.pi / PPR)  # tooth 0 just after the start angle: reported
    p = pulse_times(t, w * t, PPR, spacing_error_rad=eps)
    k, expected = _expected_with_errors(eps, w, t[-1])
    assert k[0] == 0
    np.testing.assert_allclose(p, expected, rtol=0, atol=1e-9)
    # i.e. each pulse moves by eps_k / w from its nominal time k / (ppr f)
    np.testing.assert_allclose(p - k / (PPR * f), eps[k % PPR] / w, rtol=0, atol=1e-9)


def test_spacing_error_pattern_repeats_each_revolution():
    f = 4.0
    w = 2 * np.pi * f
    t = np.arange(0, 1.0 + 1e-12, 1e-3)
    eps = tooth_errors(PPR, 0.002, rng=7)
    assert np.std(eps) == pytest.approx(0.002, rel=0.3)
    p = pulse_times(t, w * t, PPR, spacing_error_rad=eps)
    k, expected = _expected_with_errors(eps, w, t[-1])
    np.testing.assert_allclose(p, expected, rtol=0, atol=1e-9)
    # the same tooth error recurs every revolution (ppr pulses later)
    d = p[PPR:] - p[:-PPR]
    np.testing.assert_allclose(d, 1 / f, rtol=0, atol=1e-9)
    # scalar std + seed: same pattern as tooth_errors with that seed
    p2 = pulse_times(t, w * t, PPR, spacing_error_rad=0.002, rng=7)
    np.testing.assert_array_equal(p, p2)


def test_analog_channel_levels_and_edges():
    fs = 50_000.0
    t = np.arange(0, 0.02, 1 / fs)
    pulses = np.array([0.00123, 0.00711, 0.01502])
    width = 0.001
    sig = analog_channel(t, pulses, width, high=5.0, low=0.5)
    active = np.zeros_like(t, dtype=bool)
    for p in pulses:
        active |= (t >= p) & (t < p + width)
    np.testing.assert_array_equal(sig, np.where(active, 5.0, 0.5))
    # Linear edges centred on the pulse time: mid-level interpolation recovers the time.
    sig = analog_channel(t, pulses, width, edge_s=3 / fs)
    above = sig > 2.5
    rise = np.flatnonzero(~above[:-1] & above[1:])
    frac = (2.5 - sig[rise]) / (sig[rise + 1] - sig[rise])
    np.testing.assert_allclose(t[rise] + frac / fs, pulses, atol=1e-12)


def test_validation_errors():
    t = np.linspace(0, 1, 11)
    ang = np.linspace(0, 10, 11)
    back = ang.copy()
    back[7] = back[6] - 0.1
    with pytest.raises(ValueError, match="sample 7"):
        pulse_times(t, back, 10)
    nan = ang.copy()
    nan[3] = np.nan
    with pytest.raises(ValueError, match="angle contains NaN"):
        pulse_times(t, nan, 10)
    for ppr in (0, -3, 2.5):
        with pytest.raises(ValueError, match="pulses_per_rev"):
            pulse_times(t, ang, ppr)
    with pytest.raises(ValueError, match="rng"):
        pulse_times(t, ang, 10, spacing_error_rad=0.01)
    with pytest.raises(ValueError, match="half a tooth pitch"):
        pulse_times(t, ang, 10, spacing_error_rad=np.full(10, 0.4))
    with pytest.raises(ValueError, match="clock_hz"):
        pulse_times(t, ang, 10, clock_hz=0.0)
    with pytest.raises(ValueError, match="width_s"):
        analog_channel(t, [0.1], 0.0)
