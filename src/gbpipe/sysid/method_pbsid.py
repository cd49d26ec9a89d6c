"""Predictor-based subspace identification (PBSID-opt), consistent with closed-loop data.

Reference: van der Veen, van Wingerden, Bergamasco, Lovera and Verhaegen, "Closed-loop subspace
identification methods: an overview", IET Control Theory & Applications 7(10), 2013, and
Chiuso, "The role of vector autoregressive modeling in predictor-based subspace
identification", Automatica 43, 2007.

The innovation model ``x+ = A x + B u + K e``, ``y = C x + D u + e`` is rewritten as the
predictor ``x+ = (A - K C) x + (B - K D) u + K y``. Its state is a function of the past inputs
and outputs only, ``x[t] ~= sum_j Atil^(j-1) Btil z[t-j]`` once ``Atil^p ~= 0``, so feedback
(``u`` correlated with past noise) does not bias the estimate, unlike MOESP/N4SID whose
projections assume future inputs uncorrelated with the noise.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from gbpipe.errors import ConfigError
from gbpipe.sysid import checks
from gbpipe.sysid.excitation import InputRank, excitation_limit
from gbpipe.sysid.hankel import hankel_gram, lstsq_r, window_r_factor
from gbpipe.sysid.kalman import stable_predictor_gain
from gbpipe.sysid.order import check_order_rank, select_order
from gbpipe.sysid.subspace_model import SubspaceModel, from_scaled

__all__ = ["pbsid", "pbsid_leave_one_out", "pbsid_orders"]


def pbsid(
    u: object,
    y: object,
    order: int | str,
    past: int,
    future: int | None = None,
    dt: float = 1.0,
    *,
    feedthrough: bool = False,
    regularization: float = 0.0,
    max_order: int | None = None,
    factor: str = "auto",
) -> SubspaceModel:
    """Identify an innovation-form state-space model with PBSID-opt.

    Steps: (1) VARX regression of ``y[t]`` on the past window ``z[t-p..t-1]``, ``z = [u; y]``
    (and on ``u[t]`` when ``feedthrough``); (2) the product of the extended observability and
    predictor controllability matrices, ``Gamma_f K_p``, is assembled from the VARX
    coefficients (the predictor Markov parameters); (3) its SVD weighted by the past data
    gives the order and the state sequence ``x[t] = S_n^(-1/2) U_n' Gamma_f K_p z_p[t]``;
    (4) ``C, D`` from ``y = C x + D u + e`` and ``A, B, K`` from ``x+ = A x + B u + K e`` by
    least squares. Every step works on the triangular factor of the data matrix,
    accumulated in chunks, so memory is O(N).

    Parameters
    ----------
    u : array_like, shape (N,) or (N, m), or list of arrays
        Input record (any unit; channels are scaled internally). Not modified. Several
        records (experiments) as a list of numpy arrays ``[u_0, u_1, ...]``: each keeps its
        own initial state and no window straddles two records.
    y : array_like, shape (N,) or (N, l), or list of arrays
        Output record(s), same lengths as ``u``. Not modified.
    order : int or "auto"
        State dimension ``n``; ``"auto"`` picks it from the singular values.
    past : int
        Past window ``p`` in samples (VARX order). It must be long enough for the predictor
        to forget its initial state: ``|eig(A - K C)|^p << 1``.
    future : int, optional
        Future window ``f`` in samples (block rows of ``Gamma_f``), ``f <= p``; default ``p``.
    dt : float
        Sample time in seconds.
    feedthrough : bool
        Estimate ``D``. The default ``False`` is the D-free variant (``D = 0``); keep it for
        closed-loop data whose controller reacts to the current output sample, since then
        ``u[t]`` depends on ``e[t]`` and a D estimate would be biased.
    regularization : float
        Tikhonov weight of the VARX step, relative to the (unit) scaled signal power; 0 (off)
        by default. Helps with short or poorly exciting records.
    max_order : int, optional
        Upper bound of the ``"auto"`` order; default ``f * l``.
    factor : {"auto", "ridge", "gram", "qr"}
        Route to the triangular factor of the data windows
        (:func:`gbpipe.sysid.hankel.window_r_factor`); ``"auto"`` by default.

    Returns
    -------
    SubspaceModel
        With ``A - K C`` guaranteed stable.

    Raises
    ------
    DataError
        NaN/inf in the data, mismatched lengths, a record too short for the windows, an
        all-zero channel.
    ConfigError
        ``past < future``, negative ``regularization``, or an order larger than
        ``future * outputs``.
    ExcitationError
        The input is not persistently exciting for the order (:mod:`.excitation`): its
        block-Hankel matrix over the ``past + 1`` window lacks the rank the order needs.
    """
    data, p, f, dt, n_fixed = _prepared(u, y, order, past, future, dt, regularization)
    return _from_products(data, hankel_gram(data.z, p + 1), p, f, dt, n_fixed, feedthrough,
                          regularization, max_order, factor)


def pbsid_leave_one_out(
    u_groups: list[np.ndarray], y_groups: list[np.ndarray], order: int | str, past: int,
    future: int | None = None, dt: float = 1.0, *, feedthrough: bool = False,
    regularization: float = 0.0, max_order: int | None = None, factor: str = "auto",
) -> list[SubspaceModel]:
    """PBSID on every leave-one-group-out subset of ``G`` groups, for a jackknife.

    Fit ``k`` uses every group but ``k``, each as its own record (as
    ``pbsid([u_j for j != k], [y_j for j != k], ...)``), but the Gram matrix of its data
    windows is the total minus group ``k``'s, so the record is read once, not ``G`` times.
    All fits share the channel scaling of the whole data (the RMS over all groups).

    Parameters
    ----------
    u_groups, y_groups : list of ndarray
        The groups, shapes (N_k,) or (N_k, m) and (N_k,) or (N_k, l); at least 2.
    order, past, future, dt, feedthrough, regularization, max_order, factor
        As for :func:`pbsid`.

    Returns
    -------
    list of SubspaceModel
        Model ``k`` fitted without group ``k``.
    """
    data, p, f, dt, n_fixed = _prepared(list(u_groups), list(y_groups), order, past, future,
                                        dt, regularization)
    grams = [hankel_gram(z, p + 1) for z in data.z]
    total = sum(grams)
    out = []
    for k in range(len(grams)):
        rest = [z for j, z in enumerate(data.z) if j != k]
        sub = replace(data, z=rest, n_samples=sum(z.shape[1] for z in rest))
        out.append(_from_products(sub, total - grams[k], p, f, dt, n_fixed, feedthrough,
                                  regularization, max_order, factor))
    return out


def _prepared(u: object, y: object, order: int | str, past: int, future: int | None,
              dt: float, regularization: float
              ) -> tuple[checks.PreparedData, int, int, float, int | None]:
    """Checked arguments and the prepared record of :func:`pbsid`."""
    p = checks.check_window(past, "past")
    f = p if future is None else checks.check_window(future, "future")
    # The predictor rows of Gamma_f K_p need p >= f VARX coefficients.
    checks.check_past_future(p, f, "future")
    dt = checks.check_dt(dt)
    if not np.isfinite(regularization) or regularization < 0:
        raise ConfigError("regularization", f"must be >= 0, got {regularization!r}")
    # Validate shapes first so the order bound below knows the number of outputs.
    m0, l0 = checks.channel_counts(u, y)
    c0 = m0 + l0
    width = (p + 1) * c0
    n_fixed = checks.check_order(order, f * l0, f"future={f} block rows x {l0} outputs")
    data = checks.prepare(
        u, y, min_samples=p + width + 1,
        window_desc=f"past={p} with {c0} channels ({width} regressors)",
    )
    return data, p, f, dt, n_fixed


def _from_products(data: checks.PreparedData, gram: np.ndarray, p: int, f: int, dt: float,
                   n_fixed: int | None, feedthrough: bool, regularization: float,
                   max_order: int | None, factor: str = "auto") -> SubspaceModel:
    """Steps (1)-(4) of :func:`pbsid` from the prepared record and its window Gram matrix."""
    proj = _projection(data, gram, p, f, n_fixed, feedthrough, regularization, factor)
    s = proj.singular_values
    if n_fixed is None:
        top = f * data.n_outputs
        n = select_order(s, min(max_order or top, top,
                                top if proj.order_cap is None else proj.order_cap))
    else:
        n = n_fixed
    check_order_rank(s, n)
    amat, bmat, cmat, dmat, kmat, noise_cov, w, re = proj.matrices(n)
    kmat = stable_predictor_gain(amat, cmat, kmat, w.T @ w, noise_cov, w.T @ re)

    return from_scaled(
        amat, bmat, cmat, dmat, kmat, noise_cov, data.u_scale, data.y_scale,
        singular_values=s, dt=dt, method="pbsid", order=n, past=p, future=f,
        info={"n_windows": proj.n_windows, "feedthrough": feedthrough,
              "regularization": regularization, "input_hankel_rank": proj.input_rank.total,
              "input_hankel_depth": proj.input_rank.depth},
    )


def pbsid_orders(
    u: object, y: object, orders: np.ndarray, past: int, future: int | None = None,
    dt: float = 1.0, *, feedthrough: bool = False, regularization: float = 0.0,
    factor: str = "auto",
) -> list[tuple[np.ndarray, np.ndarray]]:
    """``A`` and ``C`` of PBSID at every order of ``orders`` from one projection and SVD.

    The VARX regression and the SVD of ``Gamma_f K_p`` (steps 1-3 of :func:`pbsid`) do not
    depend on the order; only the state basis (the leading ``n`` singular vectors) and the
    least squares of step 4 do. So every order is read off one projection, as SSI reads a
    stabilization diagram off one SVD, and order ``n`` gives the ``A, C`` of
    ``pbsid(u, y, n, past, future, dt, ...)`` exactly.

    Parameters
    ----------
    u, y, past, future, dt, feedthrough, regularization, factor
        As for :func:`pbsid`.
    orders : array of int
        State dimensions, each in ``1 .. future * outputs``; the input must be persistently
        exciting for the largest.

    Returns
    -------
    list of (A, C)
        One pair per order: ``A`` (n, n), ``C`` (outputs, n) in the outputs' units.

    Raises
    ------
    DataError, ConfigError, ExcitationError
        As :func:`pbsid` for the largest order; ``ConfigError`` also for an order at
        round-off level of the singular values (the data carry fewer states).
    """
    orders = np.asarray(orders, dtype=int)
    data, p, f, dt, n_max = _prepared(u, y, int(orders.max()), past, future, dt,
                                      regularization)
    proj = _projection(data, hankel_gram(data.z, p + 1), p, f, n_max, feedthrough,
                       regularization, factor)
    out = []
    for n in orders:
        check_order_rank(proj.singular_values, int(n))
        amat, _, cmat, *_ = proj.matrices(int(n))
        out.append((amat, data.y_scale[:, None] * cmat))
    return out


@dataclass(frozen=True)
class _Projection:
    """Steps (1)-(3) of :func:`pbsid`, which do not depend on the order.

    ``r`` is the triangular factor of the data windows, ``gk`` the product
    ``Gamma_f K_p`` and ``uu``, ``singular_values`` its SVD weighted by the past data;
    ``matrices(n)`` is step (4) for order ``n``.
    """

    r: np.ndarray
    gk: np.ndarray
    uu: np.ndarray
    singular_values: np.ndarray
    n_inputs: int
    n_outputs: int
    past: int
    feedthrough: bool
    input_rank: InputRank
    order_cap: int | None
    n_windows: int

    def matrices(self, n: int) -> tuple[np.ndarray, ...]:
        """Step (4) at order ``n``: ``A, B, C, D, K`` (least-squares ``K``, channel-scaled)
        and the residual factors (noise covariance, ``r``-weighted state and output
        residuals) that the Kalman-gain fallback needs."""
        m, l_, p, r = self.n_inputs, self.n_outputs, self.past, self.r
        c = m + l_
        pc = p * c
        t_x = (self.uu[:, :n] / np.sqrt(self.singular_values[:n])).T @ self.gk  # (n, pc)

        # Every signal below is a linear combination of window columns (coefficient
        # matrices): x[t] = t_x @ z_p[t], x[t+1] uses lag indices 1..p.
        width = (p + 1) * c
        cx = np.zeros((width, n))
        cx[:pc] = t_x.T
        cx_next = np.zeros((width, n))
        cx_next[c:] = t_x.T
        cu = np.zeros((width, m))
        cu[pc + np.arange(m), np.arange(m)] = 1.0
        cy = np.zeros((width, l_))
        cy[pc + m + np.arange(l_), np.arange(l_)] = 1.0

        # (4a) C, D from y = C x + D u + e.
        reg_cd = np.hstack([cx, cu]) if self.feedthrough else cx
        sol = lstsq_r(r @ reg_cd, r @ cy)
        cmat = sol[:n].T
        dmat = sol[n:].T if self.feedthrough else np.zeros((l_, m))
        ce = cy - cx @ cmat.T - cu @ dmat.T
        # (4b) A, B, K from x+ = A x + B u + K e.
        sol = lstsq_r(r @ np.hstack([cx, cu, ce]), r @ cx_next)
        amat, bmat, kmat = sol[:n].T, sol[n: n + m].T, sol[n + m:].T
        re = r @ ce
        w = r @ (cx_next - cx @ amat.T - cu @ bmat.T)
        return amat, bmat, cmat, dmat, kmat, re.T @ re, w, re


def _projection(data: checks.PreparedData, gram: np.ndarray, p: int, f: int,
                n_fixed: int | None, feedthrough: bool, regularization: float,
                factor: str) -> _Projection:
    """Steps (1)-(3) of :func:`pbsid`: VARX, ``Gamma_f K_p`` and its weighted SVD."""
    m, l_ = data.n_inputs, data.n_outputs
    c = m + l_
    pc = p * c

    # Window at time t: z[t-p], ..., z[t-1], z[t] (lag-major, channel-minor), so the VARX
    # regressors [z_p, u_t] lead the column order and the output y_t comes last.
    cols = np.array([(lag, ch) for lag in range(p + 1) for ch in range(c)])
    pe_rank, pe_cap = excitation_limit(
        gram, m, p + 1, n_fixed, feedthrough, f"past {p} + the current sample"
    )
    r, n_win = window_r_factor(data.z, p + 1, cols, gram=gram, n_predicted=l_,
                               method=factor)

    # (1) VARX: y_t = sum_j Xi_j z[t-j] (+ D u_t) + e_t.
    k_reg = pc + (m if feedthrough else 0)
    i_y = np.arange(pc + m, pc + c)
    theta = lstsq_r(r[:k_reg, :k_reg], r[:k_reg, i_y], regularization)  # (k_reg, l)
    xi = theta[:pc].T  # (l, pc): block at lag index L multiplies z[t - p + L]

    # (2) Gamma_f K_p: block row i multiplies z[t-j] by Xi_{i+j} (zero when i + j > p, the
    # truncation Atil^p ~= 0).
    gk = np.zeros((f * l_, pc))
    for i in range(f):
        # z[t-j] sits at lag index p - j; Xi_{i+j} at lag index p - i - j.
        gk[i * l_: (i + 1) * l_, i * c:] = xi[:, : pc - i * c]

    # (3) SVD of Gamma_f K_p Z_p through the factor: Z_p' = Q R[:, :pc].
    uu, s, _ = np.linalg.svd(gk @ r[:pc, :pc].T, full_matrices=False)
    return _Projection(r=r, gk=gk, uu=uu, singular_values=s, n_inputs=m, n_outputs=l_,
                       past=p, feedthrough=feedthrough, input_rank=pe_rank,
                       order_cap=pe_cap, n_windows=n_win)
