"""The virtual torque sensor on chains with a known truth (tests/virtual/chains.py:
openTorsion assemblies simulated with scipy), and its parts against independent
computations (python-control's dlqe, a time-varying RTS smoother written here)."""

from __future__ import annotations

import warnings

import control
import numpy as np
import pytest
from scipy import linalg, signal

from gbpipe.errors import ConfigError, DataError
from gbpipe.lti import fit_percent
from gbpipe.model import build_chain
from gbpipe.virtual import (
    BLOCK,
    Z95,
    NoiseModel,
    estimation_model,
    fit_noise,
    gains,
    smooth,
)
from gbpipe.virtual.smoother import innovations
from tests.virtual.chains import simulate_chain

SENSORS = ["speed_first", "speed_last"]


def _estimate(rec, sensors, target, window=3000):
    chain = build_chain(rec.description)
    last = f"n{len(rec.description['disks']) - 1}"
    model = estimation_model(chain, sensors, [target], [last], rec.dt)
    y = np.column_stack([rec.y[s] for s in sensors])
    nf = fit_noise(model, y[:window], rec.u_measured[:window])
    return model, smooth(model, nf.noise, y, rec.u_measured)


def test_unmeasured_shaft_torque_fit_and_band_over_seeds():
    """8-disk chains, the middle shaft unmeasured, two encoder speeds and the motor
    torque: fit >= 95 % against the truth on every seed, and the 95 % band holds 90-98 %
    of the samples pooled over the seeds (steady part)."""
    inside, total = 0, 0
    for seed in (0, 1, 2):
        rec = simulate_chain(seed, n_disks=8, duration=4.0)
        _, est = _estimate(rec, SENSORS, "torque_shaft3")
        k = est.steady
        truth, z = rec.torque[k, 3], est.z[k, 0]
        assert fit_percent(truth, z)[0] >= 95.0, seed
        inside += np.sum(np.abs(z - truth) <= Z95 * est.sd[0])
        total += k.sum()
    assert 0.90 <= inside / total <= 0.98


def test_motor_friction_stays_out_of_the_dynamics():
    """The motor's torque read 9 N·m above the torque it applies (friction, losses): with
    a torque sensor between motor and load the offset is estimated inside its 95 %
    interval and the unmeasured shaft's torque carries no bias beyond its band (a free
    load alone would take the 9 N·m into every shaft between)."""
    rec = simulate_chain(5, n_disks=8, duration=4.0,
                         sensors=("speed_first", "speed_last", "torque_first"))
    rec = rec._replace(u_measured=rec.u_measured + 9.0)
    sensors = ["speed_first", "speed_last", "torque_first"]
    model, est = _estimate(rec, sensors, "torque_shaft3")
    # a sensor zero and a static torque through the chain look alike: the motor's offset
    # is the one estimated, the calibrated sensor trusted
    assert model.offsets == ["offset_motor_torque_drive"]
    assert abs(est.offsets[0] + 9.0) <= Z95 * est.offsets_sd[0], (est.offsets,
                                                                   est.offsets_sd)
    k = est.steady
    bias = np.mean(est.z[k, 0] - rec.torque[k, 3])
    assert abs(bias) <= Z95 * est.sd[0]
    assert abs(bias) < 2.0     # N·m


def test_without_a_torque_sensor_the_friction_goes_to_the_load():
    """Speeds only: a motor offset and the unknown load's mean cannot be told apart (the
    PBH test), so no motor offset is estimated."""
    rec = simulate_chain(5, n_disks=5, duration=0.5)
    model = estimation_model(build_chain(rec.description), SENSORS, ["torque_shaft1"],
                             ["n4"], rec.dt)
    assert model.offsets == []
    model = estimation_model(build_chain(rec.description), SENSORS, ["torque_shaft1"],
                             [], rec.dt)
    assert model.offsets == ["offset_motor_torque_drive"]


def test_steady_gain_equals_python_control_dlqe():
    rec = simulate_chain(3, n_disks=5, duration=1.0)
    model = estimation_model(build_chain(rec.description), SENSORS, ["torque_shaft1"],
                             ["n4"], rec.dt)
    noise = NoiseModel(np.array([0.05, 0.08]), np.array([0.7]), np.array([20.0]), 0.02)
    g = gains(model, noise)
    Q, R = noise.covariances(model)
    _, P, _ = control.dlqe(model.A, np.eye(len(Q)), model.C, Q, R)
    assert np.allclose(g.P, P, rtol=1e-6, atol=1e-9 * np.abs(P).max())


def _four_disk_chain():
    """A 4-disk chain's record, its estimation model (no offsets) and a noise model: the
    case of the smoother's comparisons with a time-varying RTS smoother."""
    rec = simulate_chain(7, n_disks=4, duration=1.5)
    model = estimation_model(build_chain(rec.description), SENSORS, ["torque_shaft1"],
                             ["n3"], rec.dt, offsets=False)
    noise = NoiseModel(np.array([0.05, 0.05]), np.array([0.5]), np.array([30.0]), 0.05)
    return rec, model, noise


@pytest.mark.parametrize("block", [BLOCK, 257])
def test_smoother_equals_time_varying_rts_in_the_interior(block):
    """The steady-state smoother against the textbook time-varying Kalman filter and RTS
    smoother (a direct loop here, from a diffuse start): equal in the interior; where the
    estimate is flagged steady, the exact variance within 5 % of the steady band's. In
    one block and in blocks of 257 samples (the record's states never held at once; the
    last block partial): the same to round-off, everywhere."""
    rec, model, noise = _four_disk_chain()
    y = np.column_stack([rec.y[s] for s in SENSORS])
    u = rec.u_measured
    est = smooth(model, noise, y, u, block=block)
    assert len(y) > 4 * 257 and len(y) % 257 not in (0, 1)
    A, B, C, D = model.A, model.B, model.C, model.D
    Q, R = noise.covariances(model)
    n, N = len(A), len(y)
    x, P = np.zeros(n), np.eye(n) * 1e6
    xf, Pf, xp, Pp = [], [], [], []
    for k in range(N):
        xp.append(x), Pp.append(P)
        S = C @ P @ C.T + R
        K = P @ C.T @ np.linalg.inv(S)
        x = x + K @ (y[k] - C @ x - D @ u[k])
        P = P - K @ C @ P
        xf.append(x), Pf.append(P)
        x, P = A @ x + B @ u[k], A @ P @ A.T + Q
    xs, Ps = xf[-1], Pf[-1]
    out = np.empty(N)
    sd = np.empty(N)
    out[-1] = model.Cz[0] @ xs
    for k in range(N - 2, -1, -1):
        G = Pf[k] @ A.T @ np.linalg.inv(Pp[k + 1])
        xs = xf[k] + G @ (xs - xp[k + 1])
        Ps = Pf[k] + G @ (Ps - Pp[k + 1]) @ G.T
        out[k] = model.Cz[0] @ xs
        sd[k] = np.sqrt(model.Cz[0] @ Ps @ model.Cz[0])
    sd[-1] = np.sqrt(model.Cz[0] @ Pf[-1] @ model.Cz[0])
    mid = slice(N // 3, 2 * N // 3)
    scale = np.std(rec.torque[:, 1])
    assert np.max(np.abs(est.z[mid, 0] - out[mid])) < 1e-5 * scale
    assert np.allclose(est.sd[0], sd[mid], rtol=1e-6)
    if block != BLOCK:   # the blocked passes against the whole record's, every sample
        whole = smooth(model, noise, y, u, block=len(y))
        assert np.max(np.abs(est.z - whole.z)) < 1e-9 * np.max(np.abs(whole.z))
        assert np.array_equal(est.steady, whole.steady)
    # the samples flagged steady: the exact smoother's variance (diffuse start, as the
    # GLS initial state) within 5 % of the steady band's; the flagged ends a few time
    # constants of the predictor's slowest pole (python-control's gain, not gains())
    k = est.steady
    assert np.all(sd[k] ** 2 <= 1.05 * est.sd[0] ** 2)
    assert np.all(sd[k] ** 2 >= (1 - 1e-6) * est.sd[0] ** 2)
    _, P, _ = control.dlqe(A, np.eye(n), C, Q, R)
    Kf = P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
    tau = -1 / np.log(np.max(np.abs(np.linalg.eigvals(A - A @ Kf @ C))))   # samples
    start, end = np.argmax(k), N - 1 - np.flatnonzero(k)[-1]
    assert start <= 5 * tau and end <= 5 * tau, (start, end, tau)
    # and only the ends: one steady stretch
    assert np.all(k[start:N - end])


def test_smoothed_covariance_is_the_rts_fixed_point_without_a_warning():
    """The steady smoothed covariance Ps solves Ps = G Ps Gᵀ + Pf − G P Gᵀ: against the
    fixed point of that recursion summed in extended precision by doubling (G's spectral
    radius < 1), to 1e-12 of each entry's scale; and the states' units, decades apart
    (rad, rad/s, N·m), no longer make scipy's solver warn of an ill-conditioned system."""
    _, model, noise = _four_disk_chain()
    with warnings.catch_warnings():
        warnings.simplefilter("error", linalg.LinAlgWarning)
        g = gains(model, noise)
    d = np.sqrt(np.diag(g.P))
    assert d.max() / d.min() > 1e5   # the case that warned: scales six decades apart
    G = g.G.astype(np.longdouble)
    q = (g.Pf - g.G @ g.P @ g.G.T).astype(np.longdouble)
    assert np.max(np.abs(np.linalg.eigvals(g.G))) < 0.99
    # the recursion's sum q + G q Gᵀ + G² q G²ᵀ + ... by doubling (Smith's method):
    # after k steps 2^k terms, the rest of order rho^(2^(k+1)), rho = 0.98 here
    x, a = q, G
    for _ in range(14):
        x = x + a @ x @ a.T
        a = a @ a
    assert np.max(np.abs(a)) < 1e-30
    ref = x.astype(float)
    # relative to each entry's own scale d_i d_j: the entries span ten decades
    assert np.max(np.abs(g.Ps - ref) / np.outer(d, d)) < 1e-12


def test_torque_sensors_alone_cannot_see_the_rigid_speed():
    rec = simulate_chain(1, n_disks=4, duration=0.5, sensors=("torque_first",))
    with pytest.raises(DataError, match="speed or angle sensor"):
        estimation_model(build_chain(rec.description), ["torque_first"], ["torque_shaft1"],
                         ["n3"], rec.dt)


def test_a_measured_signal_cannot_be_held_out_at_once():
    rec = simulate_chain(1, n_disks=4, duration=0.5)
    with pytest.raises(ConfigError) as exc:
        estimation_model(build_chain(rec.description), SENSORS, ["speed_first"], ["n3"],
                         rec.dt)
    assert exc.value.field == "virtual.holdout"


def test_unknown_load_node_named():
    rec = simulate_chain(1, n_disks=4, duration=0.5)
    with pytest.raises(ConfigError) as exc:
        estimation_model(build_chain(rec.description), SENSORS, ["torque_shaft1"],
                         ["n9"], rec.dt)
    assert exc.value.field == "virtual.loads"


def test_unknown_target_named_with_the_choices():
    rec = simulate_chain(1, n_disks=4, duration=0.5)
    with pytest.raises(ConfigError) as exc:
        estimation_model(build_chain(rec.description), SENSORS, ["torque_shaft9"], [],
                         rec.dt)
    assert exc.value.field == "virtual.torques"
    assert "shaft0" in str(exc.value) and "n3" in str(exc.value)


@pytest.mark.parametrize("block", [101, 257])
def test_offsets_fit_in_blocks_equals_least_squares_over_every_sample(block):
    """The GLS of the initial state and offsets, in blocks (the samples past the free
    response's decay (250 samples) entering by their moments; the decay inside the
    first or the third block), against a least-squares fit written out here: the
    innovations by scipy's dlsim, the regressors of every sample by their recursion,
    numpy's lstsq. The residual sum and the offsets agree."""
    sensors = ["speed_first", "speed_last", "torque_first"]
    rec = simulate_chain(2, n_disks=4, duration=3.0, sensors=tuple(sensors))
    model = estimation_model(build_chain(rec.description), sensors, ["torque_shaft1"],
                             ["n3"], rec.dt)
    assert model.Gx.shape[1] >= 1   # offsets kept
    noise = NoiseModel(np.array([0.05, 0.05, 0.5]), np.array([0.5]), np.array([300.0]), 0.5)
    y = np.column_stack([rec.y[s] for s in sensors]) + [0.0, 0.0, 3.0]
    u = rec.u_measured + 2.0
    g = gains(model, noise)
    theta, _, rss = innovations(model, g, y, u, block=block)
    N, (n, nb), p = len(y), (len(model.A), model.Gx.shape[1]), y.shape[1]
    A, C, K, Phi = model.A, model.C, g.K, g.Phi
    # the free response decays (to 1e-10) well inside the record: the moments' path runs
    rho = np.max(np.abs(np.linalg.eigvals(Phi)))
    assert np.log(1e-10) / np.log(rho) < N / 4
    AK = A @ K
    W = np.linalg.inv(np.linalg.cholesky(g.S))
    e0 = signal.dlsim((Phi, np.hstack([AK, model.B - AK @ model.D]), -C,
                       np.hstack([np.eye(p), -model.D]), 1.0), np.hstack([y, u]))[1]
    Gamma = model.Gx - AK @ model.Gy
    R = np.empty((N, p, n + nb))
    Ok, S = C.copy(), np.zeros((n, nb))
    for k in range(N):
        R[k] = np.hstack([Ok, model.Gy + C @ S])
        S = Phi @ S + Gamma
        Ok = Ok @ Phi
    Rw, ew = (W @ R).reshape(N * p, -1), (e0 @ W.T).reshape(N * p)
    sol = np.linalg.lstsq(Rw, ew, rcond=None)[0]
    assert rss == pytest.approx(np.sum((ew - Rw @ sol) ** 2), rel=1e-6)
    assert np.allclose(theta[n:], sol[n:], rtol=1e-4, atol=1e-6 * np.abs(sol[n:]).max())
