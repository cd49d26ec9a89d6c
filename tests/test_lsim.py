"""Tests for gbpipe.simulate.lsim: exact ZOH simulation against independent references."""

from __future__ import annotations

import warnings

import control
import numpy as np
import pytest
import scipy.signal

import gbpipe.simulate.lsim as lsim_mod
from gbpipe.simulate.lsim import lsim


def _rel_err(y: np.ndarray, ref: np.ndarray) -> float:
    """Max over outputs of max|y - ref| / max|ref| (per-output scale)."""
    ref2 = ref.reshape(len(ref), -1)
    err = np.abs(y.reshape(ref2.shape) - ref2).max(axis=0)
    return float(np.max(err / np.maximum(np.abs(ref2).max(axis=0), 1e-300)))


def _scipy_zoh(sys: control.StateSpace, u: np.ndarray, dt: float, x0=None):
    t = np.arange(len(u)) * dt
    _, y, x = scipy.signal.lsim(
        (sys.A, sys.B, sys.C, sys.D), u, t, X0=x0, interp=False
    )
    return y.reshape(len(u), -1), x.reshape(len(u), -1)


def chain_system(angle: bool = False, pi_loop: bool = False) -> control.StateSpace:
    """Lightly damped 3-inertia free chain (twist coordinates) with a stiff actuator lag.

    States: twists (2) [rad], speeds (3) [rad/s], actuator torque [N·m], optional PI
    integral [rad] (closed speed loop), optional absolute angle of inertia 2 [rad].
    The free chain has a rigid-body eigenvalue 0; the actuator lag (tau = 1e-5 s) is far
    stiffer than the 1 ms sample interval used below. Inputs: torque command, load torque.
    Outputs: 3 speeds, shaft torque 1 (and the angle if present).
    """
    j = np.array([2.0, 0.5, 1.0])
    k = np.array([4e3, 2e3])
    c = 0.002 * k  # light stiffness-proportional damping
    tau = 1e-5
    n = 6 + int(pi_loop) + int(angle)
    a = np.zeros((n, n))
    b = np.zeros((n, 2))
    a[0, 2], a[0, 3] = 1.0, -1.0
    a[1, 3], a[1, 4] = 1.0, -1.0
    # speeds
    a[2, 0], a[2, 2], a[2, 3] = -k[0] / j[0], -c[0] / j[0], c[0] / j[0]
    a[2, 5] = 1.0 / j[0]
    a[3, 0], a[3, 1] = k[0] / j[1], -k[1] / j[1]
    a[3, 2], a[3, 3], a[3, 4] = c[0] / j[1], -(c[0] + c[1]) / j[1], c[1] / j[1]
    a[4, 1], a[4, 3], a[4, 4] = k[1] / j[2], c[1] / j[2], -c[1] / j[2]
    b[4, 1] = 1.0 / j[2]
    a[5, 5] = -1.0 / tau  # actuator lag
    b[5, 0] = 1.0 / tau
    rows = [2, 3, 4]
    if pi_loop:  # actuator command += -kp*w0 + ki*int(-w0): speed loop to 0
        ip = 6
        kp, ki = 20.0, 100.0
        a[ip, 2] = -1.0
        a[5, 2] += -kp / tau
        a[5, ip] += ki / tau
    if angle:
        ia = n - 1
        a[ia, 4] = 1.0
    cmat = np.zeros((4 + int(angle), n))
    for r, s in enumerate(rows):
        cmat[r, s] = 1.0
    cmat[3, 0] = k[0]
    if angle:
        cmat[4, n - 1] = 1.0
    return control.ss(a, b, cmat, np.zeros((cmat.shape[0], 2)))


def random_stable(n: int, m: int, p: int, seed: int, dt: float | None = None):
    """Random stable system with known modes (no global RNG: control.rss uses it)."""
    rng = np.random.default_rng(seed)
    blocks = []
    while sum(bk.shape[0] for bk in blocks) < n - 1:
        sigma, omega = -rng.uniform(0.05, 5.0), rng.uniform(1.0, 200.0)
        blocks.append(np.array([[sigma, omega], [-omega, sigma]]))
    while sum(bk.shape[0] for bk in blocks) < n:
        blocks.append(np.array([[-rng.uniform(0.1, 50.0)]]))
    a0 = np.zeros((n, n))
    i = 0
    for bk in blocks:
        a0[i : i + len(bk), i : i + len(bk)] = bk
        i += len(bk)
    q = rng.standard_normal((n, n)) + 3 * np.eye(n)
    a = q @ a0 @ np.linalg.inv(q)
    b, c, d = rng.standard_normal((n, m)), rng.standard_normal((p, n)), rng.standard_normal((p, m))
    if dt is not None:  # discrete: map through exp so it stays stable
        a = scipy.linalg.expm(a * dt)
        return control.ss(a, b, c, d, dt)
    return control.ss(a, b, c, d)


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(1234)


@pytest.mark.parametrize("method", ["auto", "modal", "block"])
def test_chain_matches_scipy_zoh(method, rng):
    sys = chain_system()
    dt, n = 1e-3, 3001
    u = rng.standard_normal((n, 2))
    x0 = rng.standard_normal(sys.nstates) * 1e-3
    y, xf, x = lsim(sys, u, dt, x0, method=method, return_states=True)
    yr, xr = _scipy_zoh(sys, u, dt, x0)
    assert y.shape == (n, 4) and x.shape == (n, sys.nstates)
    assert _rel_err(y, yr) < 1e-8
    assert _rel_err(x, xr) < 1e-8
    # x_final is the state one sample after the last one
    ad = scipy.linalg.expm(np.block([[sys.A, sys.B], [np.zeros((2, sys.nstates + 2))]]) * dt)
    x_next = ad[: sys.nstates, : sys.nstates] @ xr[-1] + ad[: sys.nstates, sys.nstates :] @ u[-1]
    np.testing.assert_allclose(xf, x_next, rtol=1e-8, atol=1e-10 * np.abs(xr).max())


def test_pi_loop_with_angle_integrator_uses_modal_and_matches(rng):
    """Closed PI loop + absolute shaft angle: simple eigenvalue 0 -> lam = 1, modal path."""
    sys = chain_system(angle=True, pi_loop=True)
    dt = 1e-3
    ad = lsim_mod.discretize_zoh(np.asarray(sys.A), np.asarray(sys.B), dt)[0]
    lam = np.linalg.eigvals(ad)
    assert np.min(np.abs(lam - 1.0)) < 1e-12  # the integrator is there
    assert lsim_mod._modal_decomposition(ad, 1e6, force=False) is not None
    u = rng.standard_normal((2500, 2))
    y, _ = lsim(sys, u, dt)
    yr, _ = _scipy_zoh(sys, u, dt)
    assert _rel_err(y, yr) < 1e-8


def test_defective_rigid_body_falls_back_to_block(rng):
    """Free chain + absolute angle: Jordan block at lam = 1; auto must still be exact."""
    sys = chain_system(angle=True)
    dt = 1e-3
    ad = lsim_mod.discretize_zoh(np.asarray(sys.A), np.asarray(sys.B), dt)[0]
    assert lsim_mod._modal_decomposition(ad, 1e6, force=False) is None
    u = rng.standard_normal((2000, 2)) + 0.3  # mean torque: the angle grows quadratically
    y, xf = lsim(sys, u, dt)
    yr, xr = _scipy_zoh(sys, u, dt)
    assert _rel_err(y, yr) < 1e-8
    with pytest.warns(RuntimeWarning, match="ill-conditioned|singular"):
        lsim(sys, u[:10], dt, method="modal")


@pytest.mark.parametrize("seed", [0, 1])
def test_random_stable_system(seed, rng):
    sys = random_stable(12, 3, 4, seed)
    u = rng.standard_normal((1500, 3))
    x0 = rng.standard_normal(12)
    yr, _ = _scipy_zoh(sys, u, 2e-3, x0)
    for method in ("modal", "block"):
        y, _ = lsim(sys, u, 2e-3, x0, method=method)
        assert _rel_err(y, yr) < 1e-8


def test_chunked_record_and_continuation(rng, monkeypatch):
    """Many chunks, a partial last block, and piecewise simulation via x_final."""
    monkeypatch.setattr(lsim_mod, "_CHUNK_SAMPLES", 256)
    sys = random_stable(8, 2, 3, seed=5)
    u = rng.standard_normal((1000, 2))
    yr, _ = _scipy_zoh(sys, u, 1e-3)
    for method in ("modal", "block"):
        y, _ = lsim(sys, u, 1e-3, method=method)
        assert _rel_err(y, yr) < 1e-8
        y1, xf1 = lsim(sys, u[:333], 1e-3, method=method)
        y2, _ = lsim(sys, u[333:], 1e-3, xf1, method=method)
        assert _rel_err(np.vstack([y1, y2]), yr) < 1e-8


def test_discrete_system_matches_dlsim(rng):
    sys = random_stable(10, 2, 3, seed=3, dt=0.01)
    u = rng.standard_normal((800, 2))
    x0 = rng.standard_normal(10)
    _, yr, _ = scipy.signal.dlsim((sys.A, sys.B, sys.C, sys.D, 0.01), u, x0=x0)
    for dt in (None, 0.01):
        y, _ = lsim(sys, u, dt, x0)
        assert _rel_err(y, yr) < 1e-8
    with pytest.raises(ValueError, match="dt"):
        lsim(sys, u, 0.02)


def test_first_order_and_integrator_analytic():
    """Exact ZOH samples: y[k] = 1 - exp(-k dt / tau) for a step; ramp for an integrator."""
    dt, n = 1e-3, 500
    k = np.arange(n)
    for tau in (0.05, 1e-5):  # the second is a stiff mode (lam ~ e^-100)
        sys = control.ss([[-1 / tau]], [[1 / tau]], [[1.0]], [[0.0]])
        y, xf = lsim(sys, np.ones(n), dt)
        np.testing.assert_allclose(y[:, 0], 1 - np.exp(-k * dt / tau), rtol=0, atol=1e-13)
        np.testing.assert_allclose(xf, [1 - np.exp(-n * dt / tau)], atol=1e-13)
    integ = control.ss([[0.0]], [[1.0]], [[1.0]], [[0.0]])
    y, xf = lsim(integ, np.full(n, 2.0), dt, x0=[0.5])
    np.testing.assert_allclose(y[:, 0], 0.5 + 2.0 * k * dt, rtol=1e-13)
    np.testing.assert_allclose(xf, [0.5 + 2.0 * n * dt], rtol=1e-13)


def test_static_gain_and_siso_shapes(rng):
    sys = control.ss(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((3, 0)), np.ones((3, 2)))
    u = rng.standard_normal((50, 2))
    y, xf = lsim(sys, u, 0.1)
    np.testing.assert_allclose(y, u @ np.ones((2, 3)))
    assert xf.shape == (0,)
    siso = control.tf([1.0], [1.0, 1.0])  # converted with control.ss
    y, _ = lsim(siso, np.ones(20), 0.1)
    assert y.shape == (20, 1)


def test_inputs_not_modified(rng):
    sys = chain_system()
    u = rng.standard_normal((300, 2))
    x0 = np.ones(sys.nstates) * 1e-3
    u0, x00, a0 = u.copy(), x0.copy(), np.array(sys.A).copy()
    lsim(sys, u, 1e-3, x0)
    np.testing.assert_array_equal(u, u0)
    np.testing.assert_array_equal(x0, x00)
    np.testing.assert_array_equal(sys.A, a0)


def test_validation_errors():
    sys = chain_system()
    u = np.zeros((10, 2))
    bad = u.copy()
    bad[4, 1] = np.nan
    with pytest.raises(ValueError, match=r"u contains NaN.*sample 4"):
        lsim(sys, bad, 1e-3)
    with pytest.raises(ValueError, match="u has shape"):
        lsim(sys, np.zeros((10, 3)), 1e-3)
    with pytest.raises(ValueError, match="u has shape"):
        lsim(sys, np.zeros(10), 1e-3)
    for dt in (0.0, -1e-3, np.inf):
        with pytest.raises(ValueError, match="dt"):
            lsim(sys, u, dt)
    with pytest.raises(ValueError, match="dt is required"):
        lsim(sys, u)
    with pytest.raises(ValueError, match="x0"):
        lsim(sys, u, 1e-3, x0=np.zeros(3))
    with pytest.raises(ValueError, match="method"):
        lsim(sys, u, 1e-3, method="euler")
    with pytest.raises(TypeError, match="sys"):
        lsim(np.eye(2), u, 1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        lsim(sys, u, 1e-3)  # well-conditioned: no warning


def test_plain_matrices_equal_control_statespace(cfg):
    """A gbpipe.model.NamedSS (plain continuous-time matrices) simulates exactly like the
    control.StateSpace built from it."""
    from gbpipe.model import bench_ss
    from gbpipe.model.statespace import to_control

    ss = bench_ss(cfg).select(["speed_ref", "torque_ref", "disturbance_driver"])
    u = np.random.default_rng(0).standard_normal((2000, 3)) * [1.0, 100.0, 10.0]
    y_plain, x_plain = lsim(ss, u, 2e-4)
    y_ctrl, x_ctrl = lsim(to_control(ss), u, 2e-4)
    np.testing.assert_array_equal(y_plain, y_ctrl)
    np.testing.assert_array_equal(x_plain, x_ctrl)
