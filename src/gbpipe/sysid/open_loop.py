"""Shared core of the open-loop subspace methods PO-MOESP and N4SID.

Both methods regress the future outputs ``Y_f`` on the future inputs ``U_f`` and the past data
``Z_p = [U_p; Y_p]`` (the instrument); the part of ``Y_f`` explained by ``Z_p`` is
``Gamma_f X`` and its column space gives the extended observability matrix ``Gamma_f``. They
differ only in the weighting of that SVD (see :func:`gbpipe.sysid.n4sid`). Then
(Verhaegen & Verdult, "Filtering and System Identification", 2007, ch. 9):

* ``C`` = first block row of ``Gamma_f``, ``A`` from its shift invariance
  ``Gamma_f[:-l] A = Gamma_f[l:]`` (least squares);
* ``B, D`` from ``Gamma_perp' Psi_u = Gamma_perp' H_f(B, D)``, linear in ``B, D``, where
  ``Psi_u`` is the regression coefficient of ``Y_f`` on ``U_f`` and ``H_f`` the block-Toeplitz
  matrix of Markov parameters. No state sequence enters, so the estimates are consistent for
  any finite horizon in open loop: they keep improving with more data.
* ``K`` and the innovation covariance from the residual covariances of the estimated state
  sequence and the Riccati equation (stable ``A - K C`` by construction).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from gbpipe.lti import dlsim
from gbpipe.sysid.checks import (
    as_2d,
    check_dt,
    check_order,
    check_past_future,
    check_window,
    prepare,
)
from gbpipe.sysid.excitation import excitation_limit
from gbpipe.sysid.hankel import hankel_gram, lstsq_r, window_r_factor
from gbpipe.sysid.kalman import kalman_gain, stable_predictor_gain
from gbpipe.sysid.order import check_order_rank, select_order
from gbpipe.sysid.subspace_model import SubspaceModel, free_response, from_scaled

__all__ = ["identify_open_loop"]


def _observability(a: np.ndarray, c: np.ndarray, rows: int) -> np.ndarray:
    l_, n = c.shape
    out = np.empty((rows * l_, n))
    ci = c
    for i in range(rows):
        out[i * l_: (i + 1) * l_] = ci
        ci = ci @ a
    return out


def _bd_regression(
    a: np.ndarray, c: np.ndarray, u: np.ndarray, y: np.ndarray, feedthrough: bool
) -> tuple[np.ndarray, np.ndarray]:
    """B, D (and a nuisance x0) by linear least squares on the whole record, A and C fixed.

    ``y[t] = C A^t x0 + sum_k C A^(t-1-k) B u[k] + D u[t]`` is linear in ``(B, D, x0)``. The
    regressor of ``B[:, j]`` on output ``r`` is the state of the transposed system
    ``s+ = A' s + C[r]' u_j``. This is the output-error optimum for the given ``A, C``, and it
    is well posed for any horizon (the ``Gamma_perp`` equations of textbook MOESP have only
    ``f l - n`` rows per block and become ill-conditioned when ``n`` is close to ``f l``).
    Memory: ``N * l * (n m + l m + n)`` regressor values.
    """
    n = a.shape[0]
    n_s, m = u.shape
    l_ = y.shape[1]
    n_b = n * m
    n_d = l_ * m if feedthrough else 0
    phi = np.zeros((n_s, l_, n_b + n_d + n))
    eye = np.eye(n)
    zero_d = np.zeros((n, 1))
    for r_ in range(l_):
        for j in range(m):
            phi[:, r_, j * n: (j + 1) * n] = dlsim(a.T, c[r_][:, None], eye, zero_d, u[:, j: j + 1])
            if feedthrough:
                phi[:, r_, n_b + r_ * m + j] = u[:, j]
    phi[:, :, n_b + n_d:] = free_response(a, c, n_s)  # (N, l, n): the nuisance x0
    # QR-based solver (gelsy): several times faster than the SVD-based default on this tall,
    # well-conditioned problem, and rank-revealing all the same.
    theta = sla.lstsq(phi.reshape(n_s * l_, -1), y.reshape(-1), lapack_driver="gelsy",
                      check_finite=False)[0]
    bmat = theta[:n_b].reshape(m, n).T
    dmat = theta[n_b: n_b + n_d].reshape(l_, m) if feedthrough else np.zeros((l_, m))
    return bmat, dmat


def _bd_gamma_perp(
    a: np.ndarray,
    c: np.ndarray,
    gperp: np.ndarray,
    psi_u: np.ndarray,
    f: int,
    m: int,
    feedthrough: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """B, D from ``Gamma_perp' Psi_u = Gamma_perp' H_f(B, D)`` (no simulation; used when the
    estimated A is unstable and simulation regressors would overflow)."""
    l_, n = c.shape
    fl = f * l_
    obs = _observability(a, c, f)
    rows_lhs, rows_rhs = [], []
    for j in range(f):
        lhs_d = np.zeros((fl, l_))
        lhs_d[j * l_: (j + 1) * l_] = np.eye(l_)
        lhs_b = np.zeros((fl, n))
        lhs_b[(j + 1) * l_:] = obs[: (f - j - 1) * l_]
        blk = [gperp.T @ lhs_b]
        if feedthrough:
            blk.insert(0, gperp.T @ lhs_d)
        rows_lhs.append(np.hstack(blk))
        rows_rhs.append(gperp.T @ psi_u[:, j * m: (j + 1) * m])
    sol = np.linalg.lstsq(np.vstack(rows_lhs), np.vstack(rows_rhs), rcond=None)[0]
    if feedthrough:
        return sol[l_:], sol[:l_]
    return sol, np.zeros((l_, m))


def identify_open_loop(
    u: object,
    y: object,
    order: int | str,
    horizon: int,
    dt: float,
    past: int | None,
    feedthrough: bool,
    max_order: int | None,
    weighting: str,
) -> SubspaceModel:
    """Identify with PO-MOESP (``weighting="moesp"``) or N4SID (``"n4sid"``).

    The arguments are those of :func:`gbpipe.sysid.moesp` (module docstring for the steps).

    Raises
    ------
    DataError, ConfigError, ExcitationError
        Bad data or arguments, or an input not persistently exciting for the order.
    """
    f = check_window(horizon, "horizon", minimum=2)
    p = f if past is None else check_window(past, "past")
    check_past_future(p, f, "horizon")
    dt = check_dt(dt)
    m0 = as_2d(u, "u").shape[1]
    l0 = as_2d(y, "y").shape[1]
    c0 = m0 + l0
    width = p * c0 + f * c0
    # Shift invariance needs Gamma_f without its last block row to keep rank n.
    n_fixed = check_order(
        order, (f - 1) * l0, f"horizon={f} (shift invariance uses {f - 1} block rows) x "
        f"{l0} outputs",
    )
    data = prepare(
        u, y, min_samples=p + f + width,
        window_desc=f"past={p} + horizon={f} with {c0} channels ({width} columns)",
    )
    m, l_ = data.n_inputs, data.n_outputs
    c = m + l_
    pc = p * c
    # Column order [U_f, Z_p, Y_f] (the PO-MOESP RQ ordering); lags p .. p+f-1 are the future.
    cols = np.array(
        [(p + i, ch) for i in range(f) for ch in range(m)]
        + [(lag, ch) for lag in range(p) for ch in range(c)]
        + [(p + i, m + ch) for i in range(f) for ch in range(l_)]
    )
    gram = hankel_gram(data.z, p + f)
    pe_rank, pe_cap = excitation_limit(
        gram, m, p + f, n_fixed, feedthrough, f"past {p} + horizon {f}"
    )
    r, n_win = window_r_factor(data.z, p + f, cols, gram=gram)
    fm, fl = f * m, f * l_
    i_yf = np.arange(fm + pc, fm + pc + fl)

    # Regression Y_f = Psi_u U_f + Psi_z Z_p (+ residual): U_f and Z_p lead the columns.
    psi = lstsq_r(r[: fm + pc, : fm + pc], r[: fm + pc, i_yf]).T  # (fl, fm + pc)
    psi_u, psi_z = psi[:, :fm], psi[:, fm:]

    if weighting == "moesp":
        # Y_f projected orthogonally to U_f, onto the part of Z_p orthogonal to U_f: L32.
        mat = r[fm: fm + pc, i_yf].T
    else:
        # N4SID: oblique projection O = Psi_z Z_p, with Z_p' = Q [R12; R22].
        mat = psi_z @ r[: fm + pc, fm: fm + pc].T
    uu, s, _ = np.linalg.svd(mat, full_matrices=True)
    s_all = s
    top = (f - 1) * l_
    if n_fixed is None:
        cap = min(max_order or top, top, top if pe_cap is None else pe_cap)
        n = select_order(s, cap)
    else:
        n = n_fixed
    check_order_rank(s, n)
    gam = uu[:, :n] * np.sqrt(s[:n])
    gperp = uu[:, n:]

    cmat = gam[:l_].copy()
    amat = np.linalg.lstsq(gam[:-l_], gam[l_:], rcond=None)[0]

    if np.max(np.abs(np.linalg.eigvals(amat))) < 1.0:
        bmat, dmat = _bd_regression(amat, cmat, data.z[:m].T, data.z[m:].T, feedthrough)
    else:
        bmat, dmat = _bd_gamma_perp(amat, cmat, gperp, psi_u, f, m, feedthrough)

    # Stochastic part: state x[t] = Gamma^+ Psi_z z_p[t]; x[t+1] uses lags 1..p, where lag p
    # (= z[t]) is the first future block. Residual covariances -> Riccati -> Kalman gain.
    tx = np.linalg.pinv(gam) @ psi_z  # (n, pc), columns ordered lag-major over lags 0..p-1
    width = cols.shape[0]
    index = {(int(lag), int(ch)): k for k, (lag, ch) in enumerate(cols)}

    def coef(lag_shift: int) -> np.ndarray:
        out = np.zeros((width, n))
        for lag in range(p):
            for ch in range(c):
                out[index[(lag + lag_shift, ch)], :] = tx[:, lag * c + ch]
        return out

    cx, cx_next = coef(0), coef(1)
    cu = np.zeros((width, m))
    cy = np.zeros((width, l_))
    for ch in range(m):
        cu[index[(p, ch)], ch] = 1.0
    for ch in range(l_):
        cy[index[(p, m + ch)], ch] = 1.0
    v = r @ (cy - cx @ cmat.T - cu @ dmat.T)
    w = r @ (cx_next - cx @ amat.T - cu @ bmat.T)
    q_, s_, r_ = w.T @ w, w.T @ v, v.T @ v
    res = kalman_gain(amat, cmat, q_, r_, s_)
    if res is not None:
        kmat, noise_cov = res
    else:
        # No stabilising Riccati solution (e.g. unstable, undetectable estimate): fall back to
        # the least-squares gain of x+ = A x + B u + K e, made stable if needed.
        kmat = lstsq_r(v, w).T
        kmat = stable_predictor_gain(amat, cmat, kmat, q_, r_, s_)
        noise_cov = r_
    return from_scaled(
        amat, bmat, cmat, dmat, kmat, noise_cov, data.u_scale, data.y_scale,
        singular_values=s_all, dt=dt, method=weighting, order=n, past=p, future=f,
        info={"n_windows": n_win, "feedthrough": feedthrough,
              "input_hankel_rank": pe_rank.total, "input_hankel_depth": pe_rank.depth},
    )
