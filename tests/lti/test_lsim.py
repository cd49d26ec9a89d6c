"""gbpipe.lti.lsim / dlsim: exact ZOH simulation against independent references."""

from __future__ import annotations

import control
import numpy as np
import pytest
import scipy.linalg
import scipy.signal
from lti_systems import (
    DT,
    eigenvector_condition,
    ill_conditioned,
    integrators,
    jordan,
    reference_zoh,
    relative_error,
)

import gbpipe.lti.simulation as simulation
from gbpipe.lti import NamedSS, dlsim, lsim
from gbpipe.lti.control_io import to_control
from gbpipe.model import bench_ss


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


def test_chain_matches_scipy_zoh(rng):
    sys = chain_system()
    dt, n = 1e-3, 3001
    u = rng.standard_normal((n, 2))
    x0 = rng.standard_normal(sys.nstates) * 1e-3
    y, xf, x = lsim(sys, u, dt, x0, return_states=True)
    yr, xr = _scipy_zoh(sys, u, dt, x0)
    assert y.shape == (n, 4) and x.shape == (n, sys.nstates)
    assert _rel_err(y, yr) < 1e-8
    assert _rel_err(x, xr) < 1e-8
    # x_final is the state one sample after the last one
    ad = scipy.linalg.expm(np.block([[sys.A, sys.B], [np.zeros((2, sys.nstates + 2))]]) * dt)
    x_next = ad[: sys.nstates, : sys.nstates] @ xr[-1] + ad[: sys.nstates, sys.nstates :] @ u[-1]
    np.testing.assert_allclose(xf, x_next, rtol=1e-8, atol=1e-10 * np.abs(xr).max())


@pytest.mark.parametrize("angle, pi_loop", [(True, True), (True, False)])
def test_chain_with_integrators_matches_scipy_zoh(angle, pi_loop, rng):
    """Absolute shaft angle: a simple eigenvalue 0 with the PI loop, a Jordan block at 0
    (free rigid body) without; a mean torque makes the free angle grow quadratically."""
    sys = chain_system(angle=angle, pi_loop=pi_loop)
    u = rng.standard_normal((2500, 2)) + 0.3
    y, _ = lsim(sys, u, 1e-3)
    yr, _ = _scipy_zoh(sys, u, 1e-3)
    assert _rel_err(y, yr) < 1e-8


@pytest.mark.parametrize("system, min_cond", [
    (ill_conditioned(1e6), 1e6),
    (ill_conditioned(1e8), 1e6),
    (jordan(), 1e12),                # defective: one Jordan block of size 6
    (jordan(eps=1e-3), 1e12),        # near-defective
    (integrators(), 1e12),           # triple integrator (Jordan block at 0) + a mode
], ids=["cond1e6", "cond1e8", "jordan", "near_jordan", "integrators"])
def test_exact_at_any_conditioning(system, min_cond, rng):
    """<= 1e-10 relative to an independent exact ZOH (block expm, extended precision)."""
    a, b, c, d = system
    assert eigenvector_condition(a) >= min_cond
    u = rng.standard_normal((20_000, b.shape[1]))
    x0 = rng.standard_normal(a.shape[0])
    y, _ = lsim(NamedSS(a, b, c, d, [], [], []), u, DT, x0)
    assert relative_error(y, reference_zoh(a, b, c, d, u, DT, x0)) <= 1e-10


@pytest.mark.parametrize("seed", [0, 1])
def test_random_stable_system(seed, rng):
    sys = random_stable(12, 3, 4, seed)
    u = rng.standard_normal((1500, 3))
    x0 = rng.standard_normal(12)
    yr, _ = _scipy_zoh(sys, u, 2e-3, x0)
    y, _ = lsim(sys, u, 2e-3, x0)
    assert _rel_err(y, yr) < 1e-8


def test_chunks_levels_and_continuation(rng, monkeypatch):
    """Many chunks, several levels of block-start lifting, a partial last block, and
    piecewise simulation via x_final, against scipy.signal.dlsim."""
    monkeypatch.setattr(simulation, "_CHUNK_SAMPLES", 256)
    monkeypatch.setattr(simulation, "_MIN_LIFTED", 2)
    monkeypatch.setattr(simulation, "_SEGMENT", 2)
    sys = random_stable(8, 2, 3, seed=5, dt=1e-3)
    u = rng.standard_normal((5003, 2))
    _, yr, _ = scipy.signal.dlsim((sys.A, sys.B, sys.C, sys.D, 1e-3), u)
    y = dlsim(sys.A, sys.B, sys.C, sys.D, u)
    assert _rel_err(y, yr) < 1e-10
    y1, xf1 = dlsim(sys.A, sys.B, sys.C, sys.D, u[:333], return_state=True)
    y2 = dlsim(sys.A, sys.B, sys.C, sys.D, u[333:], xf1)
    assert _rel_err(np.vstack([y1, y2]), yr) < 1e-10


def test_discrete_system_matches_dlsim(rng):
    sys = random_stable(10, 2, 3, seed=3, dt=0.01)
    u = rng.standard_normal((800, 2))
    x0 = rng.standard_normal(10)
    _, yr, _ = scipy.signal.dlsim((sys.A, sys.B, sys.C, sys.D, 0.01), u, x0=x0)
    for dt in (None, 0.01):
        y, _ = lsim(sys, u, dt, x0)
        assert _rel_err(y, yr) < 1e-10
    ss = NamedSS(sys.A, sys.B, sys.C, sys.D, [], [], [], dt=0.01)
    assert _rel_err(lsim(ss, u, None, x0)[0], yr) < 1e-10
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


def test_static_gain_and_shapes(rng):
    sys = control.ss(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((3, 0)), np.ones((3, 2)))
    u = rng.standard_normal((50, 2))
    y, xf = lsim(sys, u, 0.1)
    np.testing.assert_allclose(y, u @ np.ones((2, 3)))
    assert xf.shape == (0,)
    siso = control.ss(control.tf([1.0], [1.0, 1.0]))
    y, _ = lsim(siso, np.ones(20), 0.1)
    assert y.shape == (20, 1)
    np.testing.assert_allclose(y[:, 0], 1 - np.exp(-0.1 * np.arange(20)), atol=1e-13)


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
    with pytest.raises(TypeError, match="sys"):
        lsim(np.eye(2), u, 1e-3)
    with pytest.raises(TypeError, match="control.ss"):
        lsim(control.tf([1.0], [1.0, 1.0]), np.ones(5), 0.1)


def test_named_matrices_equal_control_statespace(cfg):
    """A NamedSS simulates exactly like the control.StateSpace built from it."""
    ss = bench_ss(cfg).select(["speed_ref", "torque_ref", "disturbance_driver"])
    u = np.random.default_rng(0).standard_normal((2000, 3)) * [1.0, 100.0, 10.0]
    y_plain, x_plain = lsim(ss, u, 2e-4)
    y_ctrl, x_ctrl = lsim(to_control(ss), u, 2e-4)
    np.testing.assert_array_equal(y_plain, y_ctrl)
    np.testing.assert_array_equal(x_plain, x_ctrl)
