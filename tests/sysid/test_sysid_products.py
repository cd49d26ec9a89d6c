"""The O(N) data products of the subspace methods against explicit computations.

The fast paths (block matrix products for the lagged correlations, the Gram matrix of the
``B, D`` regressors accumulated from block-start states) must give what the textbook
formulas give on explicitly formed matrices: the sliding-window Hankel matrix, and the
full-record regressor matrix of ``y = C A^t x0 + sum C A^(t-1-k) B u[k] + D u[t]`` built
with ``scipy.signal.dlsim`` and solved by ``numpy.linalg.lstsq``.
"""

import numpy as np
import pytest
import scipy.signal as sig
from sysid_plants import simulate, two_mode_plant

from gbpipe.sysid import excitation, moesp, n4sid, open_loop
from gbpipe.sysid.hankel import hankel_gram, lagged_products
from gbpipe.sysid.input_matrices import bd_least_squares


def rotation(angle: float) -> np.ndarray:
    return np.array([[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]])


def mimo_plant(radius: float):
    """2x2, 4 states: modes at pole radius ``radius`` (angle 0.3) and 0.8 (angle 1.35)."""
    A = np.zeros((4, 4))
    A[:2, :2] = radius * rotation(0.3)
    A[2:, 2:] = 0.8 * rotation(1.35)
    B = np.array([[1.0, 0.0], [0.5, 1.0], [0.0, 1.0], [1.0, -0.5]])
    C = np.array([[1.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.5, 1.0]])
    D = np.array([[0.1, 0.0], [0.2, -0.1]])
    return A, B, C, D


def explicit_bd(A, C, u, y, feedthrough):
    """Full-record regressor matrix (``scipy.signal.lfilter`` per column) and numpy lstsq."""
    n_s, m = u.shape
    l_, n = C.shape
    cols = []
    eye = np.eye(n)
    for j in range(m):  # B[:, j]: y_r[t] = C_r sum_k A^(t-1-k) e_i u_j[k]
        for i in range(n):
            cols.append(simulate(A, eye[:, i: i + 1], C, np.zeros((l_, 1)), u[:, j]).ravel())
    if feedthrough:
        for r in range(l_):
            for j in range(m):
                col = np.zeros((n_s, l_))
                col[:, r] = u[:, j]
                cols.append(col.reshape(-1))
    impulse = np.zeros(n_s + 1)
    impulse[0] = 1.0
    for i in range(n):  # x0: C A^t e_i, the impulse response through B = e_i, one step on
        cols.append(simulate(A, eye[:, i: i + 1], C, np.zeros((l_, 1)), impulse)[1:].ravel())
    theta = np.linalg.lstsq(np.column_stack(cols), y.reshape(-1), rcond=None)[0]
    b = theta[: n * m].reshape(m, n).T
    d = theta[n * m: n * m + l_ * m].reshape(l_, m) if feedthrough else np.zeros((l_, m))
    return b, d


@pytest.mark.parametrize(("channels", "length", "n"), [(2, 20, 1000), (3, 7, 503),
                                                       (2, 5, 10), (4, 12, 24), (1, 1, 3)])
def test_lagged_products_are_dot_products(channels, length, n):
    z = np.random.default_rng(length).standard_normal((channels, n))
    expected = np.array([[[z[i, : n - d] @ z[j, d:] for j in range(channels)]
                          for i in range(channels)] for d in range(length)])
    np.testing.assert_allclose(lagged_products(z, length), expected, rtol=1e-12,
                               atol=1e-12 * n)


@pytest.mark.parametrize(("length", "n"), [(6, 11), (6, 12), (6, 13), (6, 17), (9, 1000)])
def test_hankel_gram_near_the_edges_matches_the_explicit_product(length, n):
    # n = 2L - 1 takes the explicit branch; from 2L on, head and tail corrections are used.
    z = np.random.default_rng(n).standard_normal((2, n)) * np.array([[1.0], [30.0]])
    win = np.lib.stride_tricks.sliding_window_view(z, length, axis=1)
    h = win.transpose(1, 2, 0).reshape(win.shape[1], -1)
    np.testing.assert_allclose(hankel_gram(z, length), h.T @ h, rtol=1e-12,
                               atol=1e-12 * np.abs(h).max() ** 2 * n)


@pytest.mark.parametrize("feedthrough", [False, True])
def test_bd_least_squares_matches_the_explicit_regression(feedthrough):
    # Noisy 2x2 record long enough for the block products; a small chunk makes the record
    # run through many pieces, and the slow mode (radius 0.995) keeps the free response
    # alive over several of them.
    A, B, C, D = mimo_plant(radius=0.995)
    rng = np.random.default_rng(3)
    u = rng.standard_normal((9000, 2))
    _, y, _ = sig.dlsim((A, B, C, D, 1.0), u, x0=np.array([1.0, -2.0, 0.5, 0.3]))
    y = y + 0.2 * rng.standard_normal(y.shape)
    b_ref, d_ref = explicit_bd(A, C, u, y, feedthrough)
    z = np.vstack([u.T, y.T])
    for method in ("auto", "normal", "qr"):
        b, d = bd_least_squares(A, C, z, 2, feedthrough, chunk=1500, method=method)
        np.testing.assert_allclose(b, b_ref, rtol=1e-9, atol=1e-9 * np.abs(b_ref).max())
        np.testing.assert_allclose(d, d_ref, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("method", ["normal", "qr"])
def test_bd_least_squares_of_two_records_matches_the_joint_explicit_regression(method):
    # Two records share B, D, each with its own x0: the explicit regression stacks their
    # rows, with each record's x0 columns zero in the other's rows (numpy lstsq).
    A, B, C, D = mimo_plant(radius=0.995)
    n, (l_, m) = A.shape[0], D.shape
    rng = np.random.default_rng(8)
    blocks, ys, zs = [], [], []
    for k, n_s in enumerate((2500, 1800)):
        u = rng.standard_normal((n_s, m))
        _, y, _ = sig.dlsim((A, B, C, D, 1.0), u, x0=rng.standard_normal(n))
        y = y + 0.2 * rng.standard_normal(y.shape)
        eye, impulse = np.eye(n), np.zeros(n_s + 1)
        impulse[0] = 1.0
        cols = [simulate(A, eye[:, i: i + 1], C, np.zeros((l_, 1)), u[:, j]).ravel()
                for j in range(m) for i in range(n)]
        for r in range(l_):
            for j in range(m):
                col = np.zeros((n_s, l_))
                col[:, r] = u[:, j]
                cols.append(col.reshape(-1))
        x0 = np.zeros((n_s * l_, 2 * n))
        x0[:, k * n:(k + 1) * n] = np.column_stack(
            [simulate(A, eye[:, i: i + 1], C, np.zeros((l_, 1)), impulse)[1:].ravel()
             for i in range(n)])
        blocks.append(np.column_stack(cols + [x0]))
        ys.append(y.reshape(-1))
        zs.append(np.vstack([u.T, y.T]))
    theta = np.linalg.lstsq(np.vstack(blocks), np.concatenate(ys), rcond=None)[0]
    b_ref, d_ref = theta[: n * m].reshape(m, n).T, theta[n * m: n * m + l_ * m].reshape(l_, m)
    b, d = bd_least_squares(A, C, zs, m, True, chunk=1000, method=method)
    np.testing.assert_allclose(b, b_ref, rtol=1e-9, atol=1e-9 * np.abs(b_ref).max())
    np.testing.assert_allclose(d, d_ref, rtol=1e-9, atol=1e-9)


def test_bd_least_squares_recovers_the_plant_from_noise_free_data():
    A, B, C, D = two_mode_plant(d=0.3)
    u = np.random.default_rng(4).standard_normal((20_000, 1))
    _, y, _ = sig.dlsim((A, B, C, D, 1.0), u, x0=np.array([0.5, 0.0, -1.0, 2.0]))
    b, d = bd_least_squares(A, C, np.vstack([u.T, y.T]), 1, True)
    np.testing.assert_allclose(b, B, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(d, D, rtol=1e-10)


def test_shared_window_products_do_not_leak_between_records():
    # MOESP and N4SID of one record share its Gram matrix and factor (open_loop keeps
    # those of the last record) and the input ranks are remembered: a fit must equal the
    # same fit with nothing remembered, whatever was fitted before it
    A, B, C, D = two_mode_plant()
    rng = np.random.default_rng(5)
    u1, u2 = rng.standard_normal((2, 3000, 1))
    y1 = simulate(A, B, C, D, u1[:, 0]) + 0.05 * rng.standard_normal((3000, 1))
    y2 = simulate(A, B, C, D, u2[:, 0]) + 0.05 * rng.standard_normal((3000, 1))

    def fresh(fn, u, y):
        open_loop._PRODUCTS.clear()
        excitation._RANKS.clear()
        return fn(u, y, 4, 10, past=12, feedthrough=True)

    expected = [fresh(fn, u, y) for fn, u, y in
                ((moesp, u1, y1), (n4sid, u1, y1), (n4sid, u2, y2), (moesp, u1, y2))]
    got = [fn(u, y, 4, 10, past=12, feedthrough=True) for fn, u, y in
           ((moesp, u1, y1), (n4sid, u1, y1), (n4sid, u2, y2), (moesp, u1, y2))]
    for e, g in zip(expected, got, strict=True):
        for name in ("A", "B", "C", "D", "K", "noise_cov"):
            np.testing.assert_array_equal(getattr(g, name), getattr(e, name))
