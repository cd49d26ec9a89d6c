"""Subspace identification on synthetic systems with a known answer."""

import control
import numpy as np
import pytest
import scipy.signal as sig
from sysid_plants import closed_loop_data, innovation_gain, simulate, two_mode_plant

from gbpipe.errors import ConfigError
from gbpipe.lti import NamedSS
from gbpipe.lti.control_io import to_control
from gbpipe.sysid import SubspaceModel, moesp, n4sid, pbsid
from gbpipe.sysid.hankel import hankel_gram, window_r_factor
from gbpipe.sysid.kalman import stable_predictor_gain

METHODS = {
    "pbsid": lambda u, y, n, **kw: pbsid(u, y, n, past=kw.pop("past", 10), **kw),
    "moesp": lambda u, y, n, **kw: moesp(u, y, n, horizon=kw.pop("horizon", 10), **kw),
    "n4sid": lambda u, y, n, **kw: n4sid(u, y, n, horizon=kw.pop("horizon", 10), **kw),
}
FREQ = np.linspace(0.001, 0.499, 300)  # Hz at dt = 1 s


def mimo_plant():
    """4th-order 2x2 plant with two modes and full coupling, plus feedthrough."""
    A = np.array([[0.9, 0.3, 0, 0], [-0.3, 0.9, 0, 0], [0, 0, 0.2, 0.9], [0, 0, -0.9, 0.2]])
    B = np.array([[1.0, 0.0], [0.5, 1.0], [0.0, 1.0], [1.0, -0.5]])
    C = np.array([[1.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.5, 1.0]])
    D = np.array([[0.1, 0.0], [0.2, -0.1]])
    return A, B, C, D


def true_frf(A, B, C, D, f):
    z = np.exp(2j * np.pi * f)
    return np.array([C @ np.linalg.solve(zk * np.eye(A.shape[0]) - A, B) + D for zk in z])


def frf_error(model, plant):
    g = true_frf(*plant, FREQ)
    return float(np.max(np.abs(model.frf(FREQ) - g) / np.abs(g)))


def eig_error(model, A):
    a = np.sort_complex(np.linalg.eigvals(A))
    b = np.sort_complex(model.poles)
    return float(np.max(np.abs(a - b)))


def open_loop(plant, n_samples, snr_db=None, seed=0):
    rng = np.random.default_rng(seed)
    m = plant[1].shape[1]
    u = rng.standard_normal((n_samples, m))
    y0 = simulate(*plant, u)
    if snr_db is None:
        return u, y0
    noise = rng.standard_normal(y0.shape) * y0.std(axis=0) * 10 ** (-snr_db / 20)
    return u, y0 + noise


@pytest.mark.parametrize("method", METHODS)
def test_noise_free_siso_exact(method):
    plant = two_mode_plant(d=0.3)
    u, y = open_loop(plant, 3000)
    model = METHODS[method](u, y, 4, feedthrough=True)
    assert eig_error(model, plant[0]) < 1e-8
    assert frf_error(model, plant) < 1e-6
    assert abs(model.D[0, 0] - 0.3) < 1e-8
    # Noise-free: exactly four non-zero singular values, so "auto" finds the order.
    s = model.singular_values
    assert s[3] > 1e-3 * s[0] and s[4] < 1e-10 * s[0]
    assert METHODS[method](u, y, "auto", feedthrough=True).order == 4


@pytest.mark.parametrize("method", METHODS)
def test_noise_free_mimo_2x2_exact(method):
    plant = mimo_plant()
    u, y = open_loop(plant, 3000, seed=1)
    model = METHODS[method](u, y, 4, feedthrough=True, **({"past": 6} if method == "pbsid"
                                                          else {"horizon": 6}))
    assert model.B.shape == (4, 2) and model.C.shape == (2, 4)
    assert eig_error(model, plant[0]) < 1e-8
    assert frf_error(model, plant) < 1e-6


@pytest.mark.parametrize("method", METHODS)
def test_error_shrinks_with_record_length(method):
    # Innovation-form (coloured) noise at 20 dB SNR: y = G u + H e, H = C (qI - A)^-1 K + I.
    plant = two_mode_plant()
    A, B, C, D = plant
    K = innovation_gain(A, C)
    errs = []
    for n in (2_000, 200_000):
        rng = np.random.default_rng(2)
        u = rng.standard_normal((n, 1))
        y0 = simulate(A, B, C, D, u)
        e = rng.standard_normal((n, 1))
        v = simulate(A, K, C, np.eye(1), e)
        y = y0 + v * (0.1 * y0.std() / v.std())
        errs.append(frf_error(METHODS[method](u, y, 4, past=20) if method == "pbsid"
                              else METHODS[method](u, y, 4), plant))
    assert errs[1] < 0.4 * errs[0]  # 100x the data: ~10x smaller error expected
    assert errs[1] < 0.01


def test_closed_loop_pbsid_beats_moesp_n4sid():
    u, y, y0, plant, _ = closed_loop_data(20_000, snr_db=10)
    err = {name: frf_error(fn(u, y, 4, **({"past": 20} if name == "pbsid" else {})), plant)
           for name, fn in METHODS.items()}
    # PBSID consistent under feedback; the open-loop projections are biased by it.
    assert err["pbsid"] < 0.06
    assert err["pbsid"] < 0.25 * min(err["moesp"], err["n4sid"])
    model = pbsid(u, y, 4, past=20)
    fit = 100 * (1 - np.linalg.norm(y0 - model.simulate(u)[:, 0]) / np.linalg.norm(y0 - y0.mean()))
    assert fit > 98.0
    assert np.max(np.abs(np.linalg.eigvals(model.A - model.K @ model.C))) < 1.0


@pytest.mark.parametrize("method", METHODS)
def test_inputs_not_modified(method):
    u, y = open_loop(two_mode_plant(), 2000, snr_db=20, seed=4)
    u_copy, y_copy = u.copy(), y.copy()
    u.flags.writeable = False  # any in-place write would raise
    y.flags.writeable = False
    METHODS[method](u, y, 4)
    METHODS[method](u[:, 0], y[:, 0], "auto")
    np.testing.assert_array_equal(u, u_copy)
    np.testing.assert_array_equal(y, y_copy)


def test_channel_scaling_is_unit_free():
    # Same record in other units (x1e4 input, x1e-3 output) -> same model up to those units.
    u, y = open_loop(two_mode_plant(), 5000, snr_db=30, seed=5)
    m1 = pbsid(u, y, 4, past=20)
    m2 = pbsid(u * 1e4, y * 1e-3, 4, past=20)
    np.testing.assert_allclose(m2.frf(FREQ), m1.frf(FREQ) * 1e-7, rtol=1e-6)


def test_feedthrough_and_regularization_options():
    plant = two_mode_plant(d=0.5)
    u, y = open_loop(plant, 5000, snr_db=30, seed=6)
    m_d = pbsid(u, y, 4, past=20, feedthrough=True)
    m_0 = pbsid(u, y, 4, past=20)
    assert abs(m_d.D[0, 0] - 0.5) < 0.02
    assert np.all(m_0.D == 0)
    m_reg = pbsid(u, y, 4, past=20, feedthrough=True, regularization=1e-3)
    assert frf_error(m_reg, plant) < 0.1
    assert not np.allclose(m_reg.A, m_d.A)


def test_model_helpers_against_independent_computations():
    plant = two_mode_plant(d=0.2)
    u, y = open_loop(plant, 3000, seed=7)
    model = pbsid(u, y, 4, past=10, dt=0.001, feedthrough=True)
    assert isinstance(model, SubspaceModel) and model.dt == 0.001 and model.order == 4
    # FRF against scipy.signal's evaluation of the same discrete system.
    f = np.array([1.0, 50.0, 120.0, 300.0])
    _, g_ref = sig.dfreqresp((model.A, model.B, model.C, model.D, 0.001),
                             w=2 * np.pi * f * 0.001)
    np.testing.assert_allclose(model.frf(f), g_ref.reshape(4, 1, 1), rtol=1e-10)
    # The same grid again (remembered): still scipy's values, and a caller writing into one
    # result changes neither the next one nor another grid's.
    first = model.frf(f)
    first[:] = 0.0
    np.testing.assert_allclose(model.frf(f), g_ref.reshape(4, 1, 1), rtol=1e-10)
    _, g_2 = sig.dfreqresp((model.A, model.B, model.C, model.D, 0.001),
                           w=2 * np.pi * f[:2] * 0.001)
    np.testing.assert_allclose(model.frf(f[:2]), g_2.reshape(2, 1, 1), rtol=1e-10)
    # Simulation against scipy.signal.dlsim, with a non-zero initial state.
    x0 = np.array([0.3, -0.2, 0.1, 0.5])
    _, y_ref, _ = sig.dlsim((model.A, model.B, model.C, model.D, 0.001), u[:500], x0=x0)
    np.testing.assert_allclose(model.simulate(u[:500], x0), y_ref, rtol=1e-9, atol=1e-10)
    # Initial-state estimate recovers x0; fit is 100 % for the exact model.
    y_x0 = model.simulate(u[:500], x0)
    np.testing.assert_allclose(model.estimate_x0(u[:500], y_x0), x0, atol=1e-8)
    np.testing.assert_allclose(model.fit(u[:500], y_x0), [100.0], atol=1e-6)


def test_data_products_match_explicit_hankel():
    rng = np.random.default_rng(8)
    z = rng.standard_normal((3, 400))
    length = 6
    win = np.lib.stride_tricks.sliding_window_view(z, length, axis=1)  # (c, windows, L)
    h = win.transpose(1, 2, 0).reshape(win.shape[1], -1)  # columns lag * c + channel
    np.testing.assert_allclose(hankel_gram(z, length), h.T @ h, rtol=1e-12, atol=1e-10)
    cols = np.array([(lag, ch) for lag in range(length) for ch in range(3)])[::-1]
    hc = h[:, cols[:, 0] * 3 + cols[:, 1]] / np.sqrt(h.shape[0])
    for method in ("qr", "gram"):
        r, n_win = window_r_factor(z, length, cols, chunk_rows=37, method=method)
        assert n_win == h.shape[0]
        np.testing.assert_allclose(r.T @ r, hc.T @ hc, atol=1e-12)
        assert np.allclose(r, np.triu(r))


def test_ridge_route_is_the_factor_of_the_data_plus_white_noise():
    # a deeply low-passed record (as the identify stage's decimated ones): its Gram matrix
    # is singular to working precision, so the plain Gram factor does not exist
    rng = np.random.default_rng(5)
    sos = sig.butter(12, 0.3, output="sos")
    z = sig.sosfilt(sos, rng.standard_normal((2, 6000)), axis=1)
    z /= z.std(axis=1, keepdims=True)
    length = 40
    cols = np.array([(lag, ch) for lag in range(length) for ch in range(2)])
    g = hankel_gram(z, length)
    n_win = 6000 - length + 1
    r, _ = window_r_factor(z, length, cols, method="ridge")
    # exactly the Cholesky factor of the Gram matrix plus the documented ridge
    # (10 eps sqrt(N) times the largest diagonal entry): white noise at ~ -125 dB
    gs = g / n_win
    assert np.linalg.cond(gs) > 1e16  # the plain Gram route is not usable here
    ridge = 10 * np.finfo(float).eps * np.sqrt(n_win) * np.max(np.diag(gs))
    np.testing.assert_allclose(r.T @ r, gs + ridge * np.eye(gs.shape[0]), atol=1e-12)
    # and within that ridge of the QR route's (exact) factor
    r_qr, _ = window_r_factor(z, length, cols, method="qr")
    assert np.max(np.abs(r.T @ r - r_qr.T @ r_qr)) < 10 * ridge
    with pytest.raises(ConfigError, match="factor"):
        window_r_factor(z, length, cols, method="cholesky")


def test_stable_predictor_gain_repairs_unstable_gain():
    A, B, C, _ = two_mode_plant()
    k_bad = np.full((4, 1), 5.0)
    assert np.max(np.abs(np.linalg.eigvals(A - k_bad @ C))) > 1
    k = stable_predictor_gain(A, C, k_bad, 0.01 * np.eye(4), np.eye(1), np.zeros((4, 1)))
    assert np.max(np.abs(np.linalg.eigvals(A - k @ C))) < 1


def test_ss_is_the_lti_state_space_and_converts_to_control():
    u, y = open_loop(two_mode_plant(), 2000, seed=9)
    model = moesp(u, y, 4, horizon=8, dt=0.01)
    ss = model.ss
    assert isinstance(ss, NamedSS)
    assert ss.dt == 0.01 and ss.inputs == ["u[0]"] and ss.outputs == ["y[0]"]
    np.testing.assert_array_equal(ss.A, model.A)
    np.testing.assert_array_equal(ss.D, model.D)
    # At the public boundary: python-control evaluates the same transfer function.
    sys = to_control(ss)
    assert isinstance(sys, control.StateSpace) and sys.nstates == 4 and sys.dt == 0.01
    f = np.array([0.5, 7.0, 31.0])
    g_ctrl = np.array([sys(np.exp(2j * np.pi * fk * 0.01)) for fk in f]).reshape(3, 1, 1)
    np.testing.assert_allclose(model.frf(f), g_ctrl, rtol=1e-10)
