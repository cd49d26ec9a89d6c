"""Shared core of the open-loop subspace methods PO-MOESP and N4SID.

Both methods regress the future outputs ``Y_f`` on the future inputs ``U_f`` and the past data
``Z_p = [U_p; Y_p]`` (the instrument); the part of ``Y_f`` explained by ``Z_p`` is
``Gamma_f X`` and its column space gives the extended observability matrix ``Gamma_f``. They
differ only in the weighting of that SVD (see :func:`gbpipe.sysid.n4sid`). Then
(Verhaegen & Verdult, "Filtering and System Identification", 2007, ch. 9):

* ``C`` = first block row of ``Gamma_f``, ``A`` from its shift invariance
  ``Gamma_f[:-l] A = Gamma_f[l:]`` (least squares);
* ``B, D`` (:mod:`gbpipe.sysid.input_matrices`) by least squares over the whole record with
  ``A, C`` fixed (output error), or, for an unstable ``A``, in predictor form with the
  Kalman gain of unit covariances (``A - K C`` stable). No state sequence enters, so the
  estimates are consistent for any finite horizon in open loop: they keep improving with
  more data.
* ``K`` and the innovation covariance from the residual covariances of the estimated state
  sequence and the Riccati equation (stable ``A - K C`` by construction).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from gbpipe.memo import ArrayMemo, array_key
from gbpipe.sysid.checks import (
    PreparedData,
    channel_counts,
    check_dt,
    check_order,
    check_past_future,
    check_window,
    prepare,
)
from gbpipe.sysid.excitation import InputRank, excitation_limit
from gbpipe.sysid.hankel import hankel_gram, lstsq_r, records, window_r_factor
from gbpipe.sysid.input_matrices import bd_least_squares
from gbpipe.sysid.kalman import kalman_gain, stable_predictor_gain
from gbpipe.sysid.order import check_order_rank, select_order
from gbpipe.sysid.subspace_model import SubspaceModel, from_scaled

__all__ = ["identify_open_loop", "open_loop_method", "open_loop_orders", "shift_invariance"]

# The window products of the last records fitted: MOESP and N4SID of one record (same data,
# windows and factor route) share the Gram matrix and its factor, the costliest steps
# after the B, D least squares.
_PRODUCTS = ArrayMemo(4)


def _record_products(z: np.ndarray | list[np.ndarray], key: tuple,
                     compute: Callable[[], Any]) -> Any:
    """``compute()``, or its remembered value for the same record and ``key``."""
    return _PRODUCTS((key, array_key(*records(z))), compute)


def open_loop_method(weighting: str, doc: str, module: str) -> Callable[..., SubspaceModel]:
    """Build the public function of one open-loop method; both share this one signature.

    PO-MOESP and N4SID take the same arguments and differ only in the weighting of the SVD,
    so their signature is written once, here, and each method module supplies its name and
    docstring.

    Parameters
    ----------
    weighting : {"moesp", "n4sid"}
        Method; also the function's name.
    doc : str
        The function's docstring (numpydoc).
    module : str
        Module the function belongs to (its ``__module__``, for documentation tools).

    Returns
    -------
    callable
        ``f(u, y, order, horizon, dt=1.0, *, past=None, feedthrough=False,
        max_order=None, factor="auto") -> SubspaceModel``.
    """

    def method(
        u: object,
        y: object,
        order: int | str,
        horizon: int,
        dt: float = 1.0,
        *,
        past: int | None = None,
        feedthrough: bool = False,
        max_order: int | None = None,
        factor: str = "auto",
    ) -> SubspaceModel:
        return identify_open_loop(
            u, y, order, horizon, dt, past, feedthrough, max_order, weighting, factor
        )

    method.__name__ = method.__qualname__ = weighting
    method.__doc__ = doc
    method.__module__ = module
    return method


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
    factor: str = "auto",
) -> SubspaceModel:
    """Identify with PO-MOESP (``weighting="moesp"``) or N4SID (``"n4sid"``).

    The arguments are those of :func:`gbpipe.sysid.moesp` (module docstring for the steps).

    Raises
    ------
    DataError, ConfigError, ExcitationError
        Bad data or arguments, or an input not persistently exciting for the order.
    """
    sub = _subspace(u, y, order, horizon, dt, past, feedthrough, weighting, factor)
    data, p, f, dt, n_fixed = sub.data, sub.past, sub.horizon, sub.dt, sub.n_fixed
    cols, r, n_win, psi_z, uu, s = sub.cols, sub.r, sub.n_windows, sub.psi_z, sub.uu, sub.s
    pe_rank, pe_cap = sub.input_rank, sub.order_cap
    m, l_ = data.n_inputs, data.n_outputs
    c = m + l_
    s_all = s
    top = (f - 1) * l_
    if n_fixed is None:
        cap = min(max_order or top, top, top if pe_cap is None else pe_cap)
        n = select_order(s, cap)
    else:
        n = n_fixed
    check_order_rank(s, n)
    amat, cmat, gam = shift_invariance(uu, s, n, l_)

    # An unstable A (e.g. a spurious pole in the empty band of a low-passed record) would
    # overflow the output-error regressors: predictor form with a stabilising gain, that of
    # unit state and output covariances (the channels are scaled to unit rms). It is not the
    # estimated noise model, which needs B: a second pass with that gain took the 5 Hz
    # error of a closed-loop bench torque pairing from 1.7 to 39 dB.
    zero = np.zeros((n, l_))
    gain = stable_predictor_gain(amat, cmat, zero, np.eye(n), np.eye(l_), zero)
    bmat, dmat = bd_least_squares(amat, cmat, data.z, m, feedthrough,
                                  gain=gain if np.any(gain) else None)

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


def open_loop_orders(u: object, y: object, orders: np.ndarray, horizon: int, dt: float,
                     past: int | None, weighting: str, factor: str = "auto"
                     ) -> list[tuple[np.ndarray, np.ndarray]]:
    """``A`` and ``C`` of PO-MOESP or N4SID at every order of ``orders`` from one SVD.

    The projection and its SVD do not depend on the order; each order takes the leading
    singular vectors (:func:`shift_invariance`), as SSI reads its stabilization diagram,
    and gives the ``A, C`` of ``moesp``/``n4sid`` at that order exactly.

    Parameters
    ----------
    u, y, horizon, dt, past, weighting, factor
        As for :func:`identify_open_loop`.
    orders : array of int
        State dimensions, each in ``1 .. (horizon - 1) * outputs``; the input must be
        persistently exciting for the largest.

    Returns
    -------
    list of (A, C)
        Per order, as :func:`gbpipe.sysid.method_pbsid.pbsid_orders`.

    Raises
    ------
    DataError, ConfigError, ExcitationError
        As :func:`gbpipe.sysid.method_pbsid.pbsid_orders`, for these methods' windows.
    """
    orders = np.asarray(orders, dtype=int)
    sub = _subspace(u, y, int(orders.max()), horizon, dt, past, False, weighting, factor)
    out = []
    for n in orders:
        check_order_rank(sub.s, int(n))
        amat, cmat, _ = shift_invariance(sub.uu, sub.s, int(n), sub.data.n_outputs)
        out.append((amat, sub.data.y_scale[:, None] * cmat))
    return out


def shift_invariance(uu: np.ndarray, s: np.ndarray, n: int, n_outputs: int
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``A``, ``C`` and ``Gamma_f`` of order ``n`` from the SVD of the projection.

    ``Gamma_f = U_n S_n^(1/2)``; ``C`` is its first block row and ``A`` solves
    ``Gamma_f[:-l] A = Gamma_f[l:]`` in least squares.
    """
    gam = uu[:, :n] * np.sqrt(s[:n])
    cmat = gam[:n_outputs].copy()
    amat = np.linalg.lstsq(gam[:-n_outputs], gam[n_outputs:], rcond=None)[0]
    return amat, cmat, gam


@dataclass(frozen=True)
class _Subspace:
    """The order-independent part of PO-MOESP/N4SID: the checked record, its window
    factor ``r``, the regression ``psi_z`` on the past and the SVD ``uu, s``."""

    data: PreparedData
    past: int
    horizon: int
    dt: float
    n_fixed: int | None
    cols: np.ndarray
    r: np.ndarray
    n_windows: int
    psi_z: np.ndarray
    uu: np.ndarray
    s: np.ndarray
    input_rank: InputRank
    order_cap: int | None


def _subspace(u: object, y: object, order: int | str, horizon: int, dt: float,
              past: int | None, feedthrough: bool, weighting: str, factor: str) -> _Subspace:
    """Checks, window factor, regression and SVD of :func:`identify_open_loop`."""
    f = check_window(horizon, "horizon", minimum=2)
    p = f if past is None else check_window(past, "past")
    check_past_future(p, f, "horizon")
    dt = check_dt(dt)
    m0, l0 = channel_counts(u, y)
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
    gram = _record_products(data.z, ("gram", p + f), lambda: hankel_gram(data.z, p + f))
    pe_rank, pe_cap = excitation_limit(
        gram, m, p + f, n_fixed, feedthrough, f"past {p} + horizon {f}"
    )
    r, n_win = _record_products(
        data.z, ("factor", p, f, m, factor),
        lambda: window_r_factor(data.z, p + f, cols, gram=gram, n_predicted=f * l_,
                                method=factor))
    fm, fl = f * m, f * l_
    i_yf = np.arange(fm + pc, fm + pc + fl)

    # Regression Y_f = Psi_u U_f + Psi_z Z_p (+ residual): U_f and Z_p lead the columns.
    psi = lstsq_r(r[: fm + pc, : fm + pc], r[: fm + pc, i_yf]).T  # (fl, fm + pc)
    psi_z = psi[:, fm:]

    if weighting == "moesp":
        # Y_f projected orthogonally to U_f, onto the part of Z_p orthogonal to U_f: L32.
        mat = r[fm: fm + pc, i_yf].T
    else:
        # N4SID: oblique projection O = Psi_z Z_p, with Z_p' = Q [R12; R22].
        mat = psi_z @ r[: fm + pc, fm: fm + pc].T
    uu, s, _ = np.linalg.svd(mat, full_matrices=False)
    return _Subspace(data=data, past=p, horizon=f, dt=dt, n_fixed=n_fixed, cols=cols, r=r,
                     n_windows=n_win, psi_z=psi_z, uu=uu, s=s, input_rank=pe_rank,
                     order_cap=pe_cap)
