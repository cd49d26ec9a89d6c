"""``B`` and ``D`` of a state-space model whose ``A`` and ``C`` are known.

Two estimators, used by the open-loop methods (:mod:`gbpipe.sysid.open_loop`):

* :func:`bd_least_squares`: linear least squares over the whole record. With ``A, C`` fixed,
  ``y[t] = C A^t x0 + sum_k C A^(t-1-k) B u[k] + D u[t]`` is linear in ``(B, D, x0)``; the
  regressor of ``B[:, j]`` on output ``r`` is the state of the transposed system
  ``s+ = A' s + C[r]' u_j``. This is the output-error optimum for the given ``A, C`` and is
  well posed for any horizon. The record is processed in pieces and only the Gram matrix
  of the regressors is kept, so the memory is that of one piece, not ``N x (n m + l m + n)``;
  once the free response has decayed, the Gram matrix comes from block products without
  the per-sample regressors (:class:`_Regressors`).
* :func:`bd_gamma_perp`: ``Gamma_perp' Psi_u = Gamma_perp' H_f(B, D)`` on the small
  regression coefficients, no simulation (for an unstable ``A``, whose regressors would
  overflow).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from gbpipe.lti import dlsim
from gbpipe.sysid.hankel import qr_append

__all__ = ["bd_least_squares", "bd_gamma_perp"]

# Samples per chunk of regressors: a few MB of temporaries, and few enough chunks that the
# per-call cost of the simulations stays small against the work per sample.
_CHUNK_SAMPLES = 1 << 17
# Block length of the block products (_Regressors.block_gram) and the fewest blocks for
# which they pay off over the sample-by-sample regressors.
_BLOCK = 16
_MIN_BLOCKS = 64
# The chunks grow from this size (doubling) to _CHUNK_SAMPLES, so that a free response
# that decays within a few thousand samples is simulated over a few thousand samples only.
_FIRST_CHUNK = 1 << 12

# Largest condition number of the column-scaled regressor factor for which the normal
# equations are trusted. Their rounding error is ~ eps * cond^2 (1e-10 at 3e2 .. 2e-8 at
# 1e4), against eps * cond for the QR route, which is taken above this bound.
_NORMAL_MAX_COND = 1e3

# A free response below this fraction of its start (|C A^t| against |C|) contributes
# nothing to the normal equations at float64 precision; later chunks leave it at zero.
_FREE_DECAYED = 1e-20


def _observability(a: np.ndarray, c: np.ndarray, rows: int) -> np.ndarray:
    """Extended observability matrix ``[C; C A; ...; C A^(rows-1)]``, shape (rows l, n)."""
    l_, n = c.shape
    out = np.empty((rows * l_, n))
    ci = c
    for i in range(rows):
        out[i * l_: (i + 1) * l_] = ci
        ci = ci @ a
    return out


class _Regressors:
    """The regressors of :func:`bd_least_squares`, simulated piece by piece over the record.

    The simulations carry their states from piece to piece, so consecutive pieces join
    seamlessly: ``s_(r,j)``, the state of ``s+ = A' s + C[r]' u_j`` (the regressors of
    ``B[:, j]`` on output ``r``), and the free response ``(C A^t)[r]`` (those of ``x0``).
    A piece is either simulated sample by sample (:meth:`explicit`) or, once the free
    response has decayed, reduced to block products (:meth:`add_blocks`, :meth:`block_gram`).

    Parameters
    ----------
    a, c : ndarray
        ``A`` (n, n) and ``C`` (l, n).
    z : ndarray, shape (m + l, N)
        Inputs (first ``m`` rows) and outputs.
    n_inputs : int
        ``m``.
    length : int
        Block length ``L`` of the block products, in samples.
    """

    def __init__(self, a: np.ndarray, c: np.ndarray, z: np.ndarray, n_inputs: int,
                 length: int) -> None:
        n, l_ = a.shape[0], c.shape[0]
        self.n, self.m, self.c, self.z, self.length = n, n_inputs, c, z, length
        self.at = np.ascontiguousarray(a.T)
        self.s_b = np.zeros((l_, n_inputs, n))
        self.s_f = c.astype(float, copy=True)
        self.free_floor = _FREE_DECAYED * max(float(np.max(np.abs(c))), np.finfo(float).tiny)
        # Powers of A' in extended precision, rounded once (as in gbpipe.lti.dlsim): the
        # lifted recursion s_(b+1) = (A')^L s_b + R u_b runs over N / L blocks.
        pw = np.empty((length + 1, n, n), dtype=np.longdouble)
        pw[0] = np.eye(n)
        for q in range(1, length + 1):
            pw[q] = self.at.astype(np.longdouble) @ pw[q - 1]
        self.powers = pw
        self.markov = pw[:length] @ c.T.astype(np.longdouble)  # [q] = (A')^q C', (L, n, l)
        self.n_states = l_ * n_inputs * n
        self.gram_v = np.zeros((self.n_states + (n_inputs + l_) * length,) * 2)

    @property
    def free(self) -> bool:
        """Whether the free response is still above float64 resolution (else zero)."""
        return bool(np.max(np.abs(self.s_f)) > self.free_floor)

    def explicit(self, t0: int, t1: int) -> tuple[np.ndarray, list[np.ndarray], bool]:
        """Regressors of samples ``t0 .. t1 - 1``, sample by sample.

        Returns
        -------
        zc : ndarray, shape (m + l, T)
            The record over the piece (a view).
        xs : list of ndarray, one per output ``r``, shape (T, n + n m) or (T, n m)
            ``[(C A^t)[r], s_(r,0), ..., s_(r,m-1)]``; the free response is left out
            when ``free`` is False.
        free : bool
        """
        n = self.n
        eye, zero_n1 = np.eye(n), np.zeros((n, 1))
        zc = self.z[:, t0:t1]
        free = self.free
        xs = []
        for r_ in range(self.c.shape[0]):
            parts = []
            if free:
                # (C A^t)[r] is the unforced state of the transposed system from C[r]'.
                resp, self.s_f[r_] = dlsim(self.at, zero_n1, eye, zero_n1,
                                           np.zeros((t1 - t0, 1)), x0=self.s_f[r_],
                                           return_state=True)
                parts.append(resp)
            for j in range(self.m):
                states, self.s_b[r_, j] = dlsim(
                    self.at, self.c[r_][:, None], eye, zero_n1, zc[j][:, None],
                    x0=self.s_b[r_, j], return_state=True,
                )
                parts.append(states)
            xs.append(parts[0] if len(parts) == 1 else np.hstack(parts))
        return zc, xs, free

    def add_blocks(self, t0: int, n_blocks: int) -> None:
        """Accumulate ``V = sum_b v_b v_b'`` over ``n_blocks`` blocks from sample ``t0``.

        ``v_b = [s_b (all r, j); u block; y block]``: the states at the block start and
        the block's samples. Only the block starts are simulated (the lifted system), not
        the states at every sample. Only for a decayed free response.
        """
        n, m, L, ns = self.n, self.m, self.length, self.n_states
        l_ = self.c.shape[0]
        seg = self.z[:, t0: t0 + n_blocks * L].reshape(m + l_, n_blocks, L)
        v = np.empty((n_blocks, self.gram_v.shape[0]))
        for r_ in range(l_):
            lifted_b = self.markov[::-1, :, r_].T  # column i: (A')^(L-1-i) C[r]'
            for j in range(m):
                col = (r_ * m + j) * n
                v[:, col: col + n], self.s_b[r_, j] = dlsim(
                    self.powers[L], lifted_b, np.eye(n), np.zeros((n, L)), seg[j],
                    x0=self.s_b[r_, j], return_state=True,
                )
        v[:, ns:] = seg.transpose(1, 0, 2).reshape(n_blocks, (m + l_) * L)
        self.gram_v += v.T @ v

    def block_gram(self, feedthrough: bool) -> np.ndarray:
        """Gram matrix of ``[Phi y]`` over the blocks of :meth:`add_blocks`.

        Within a block starting at ``t_b``, the regressor at ``t_b + k`` is
        ``(A')^k s_b`` plus a Toeplitz product with the block's inputs, so every row of
        ``[Phi y]`` there is ``F_(r,k) v_b``, and the Gram matrix is
        ``sum_(r,k) F_(r,k) V F_(r,k)'``.

        Returns
        -------
        ndarray, shape (k + 1, k + 1)
            Symmetric; columns ``[x0 (zero), B, D, y]`` as in :func:`bd_least_squares`.
        """
        n, m, L, ns = self.n, self.m, self.length, self.n_states
        l_ = self.c.shape[0]
        nb = n + n * m
        k = nb + (l_ * m if feedthrough else 0)
        toep = np.zeros((L, n, L, l_))  # toep[q, :, i, r] = (A')^(q-1-i) C[r]', i < q
        for q in range(1, L):
            toep[q, :, :q, :] = self.markov[q - 1:: -1].transpose(1, 0, 2).astype(float)
        f_all = np.zeros((l_, L, k + 1, self.gram_v.shape[0]))
        samples = np.arange(L)
        for r_ in range(l_):
            for j in range(m):
                rows = slice(n + j * n, n + (j + 1) * n)
                col, u0 = (r_ * m + j) * n, ns + j * L
                f_all[r_, :, rows, col: col + n] = self.powers[:L].astype(float)
                f_all[r_, :, rows, u0: u0 + L] = toep[:, :, :, r_]
                if feedthrough:
                    f_all[r_, samples, nb + r_ * m + j, u0 + samples] = 1.0
            f_all[r_, samples, k, ns + (m + r_) * L + samples] = 1.0
        f_all = f_all.reshape(l_ * L, k + 1, -1)
        fv = (f_all @ self.gram_v).transpose(1, 0, 2).reshape(k + 1, -1)
        return fv @ f_all.transpose(1, 0, 2).reshape(k + 1, -1).T


def _explicit_rows(
    zc: np.ndarray, x: np.ndarray, r_: int, n: int, n_inputs: int, feedthrough: bool
) -> np.ndarray:
    """Rows ``[x0, B, D, y]`` of output ``r`` for one chunk (the QR route)."""
    m = n_inputs
    l_ = zc.shape[0] - m
    nb = n + n * m
    nd = l_ * m if feedthrough else 0
    rows = np.zeros((zc.shape[1], nb + nd + 1))
    rows[:, nb - x.shape[1]: nb] = x  # x0 columns stay zero once the free response decayed
    if feedthrough:
        rows[:, nb + r_ * m: nb + (r_ + 1) * m] = zc[:m].T
    rows[:, -1] = zc[m + r_]
    return rows


def bd_least_squares(
    a: np.ndarray,
    c: np.ndarray,
    z: np.ndarray,
    n_inputs: int,
    feedthrough: bool,
    chunk: int = _CHUNK_SAMPLES,
    method: str = "auto",
) -> tuple[np.ndarray, np.ndarray]:
    """``B, D`` (and a nuisance ``x0``) by least squares over the whole record, ``A, C`` fixed.

    The Gram matrix of the regressors and the output, ``[Phi y]' [Phi y]``, is accumulated
    chunk by chunk from products of the simulated regressors with each other and with the
    record. Its Cholesky factor is the triangular factor of ``[Phi y]`` and solves the
    problem when the (column-scaled) regressors are well conditioned; otherwise a second
    pass accumulates the factor by Householder QR (backward stable, like a direct QR solve
    of the full problem).

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix (stable: the regressors are simulations of its transpose).
    c : ndarray, shape (l, n)
    z : ndarray, shape (m + l, N)
        Channel-scaled inputs (first ``m`` rows) and outputs, one channel per row.
    n_inputs : int
        Number of inputs ``m``.
    feedthrough : bool
        Estimate ``D``; otherwise ``D = 0``.
    chunk : int
        Largest piece of the record simulated at once, in samples.
    method : {"auto", "normal", "qr"}
        ``"normal"``: the normal equations (Cholesky of the Gram matrix); ``"qr"``: the
        Householder QR pass; ``"auto"`` (default): the normal equations when the
        column-scaled factor has ``cond <= 1e3`` (rounding ~ ``eps cond^2`` <= 2e-10),
        else QR.

    Returns
    -------
    B : ndarray, shape (n, m)
    D : ndarray, shape (l, m)
    """
    if method not in ("auto", "normal", "qr"):
        raise ValueError(f"method must be 'auto', 'normal' or 'qr', got {method!r}")
    n = a.shape[0]
    m = n_inputs
    l_ = c.shape[0]
    nb = n + n * m  # x0 and B columns
    k = nb + (l_ * m if feedthrough else 0)
    gram = np.zeros((k + 1, k + 1))  # columns [x0, B, D, y]; upper triangle from pieces
    sim = _Regressors(a, c, z, m, _BLOCK)
    t0, size = 0, min(_FIRST_CHUNK, chunk)
    while t0 < z.shape[1]:
        n_blocks = min(z.shape[1] - t0, chunk) // _BLOCK
        if not sim.free and n_blocks >= _MIN_BLOCKS:
            sim.add_blocks(t0, n_blocks)
            t0 += n_blocks * _BLOCK
            continue
        t1 = min(t0 + size, z.shape[1])
        zc, xs, free = sim.explicit(t0, t1)
        t0, size = t1, min(2 * size, chunk)
        lo = 0 if free else n  # the x0 columns are zero once the free response decayed
        zz = zc @ zc.T
        for r_, x in enumerate(xs):
            xz = x.T @ zc.T  # products with every input and output channel
            gram[lo:nb, lo:nb] += x.T @ x
            gram[lo:nb, k] += xz[:, m + r_]
            gram[k, k] += zz[m + r_, m + r_]
            if feedthrough:
                d = slice(nb + r_ * m, nb + (r_ + 1) * m)
                gram[lo:nb, d] += xz[:, :m]
                gram[d, d] += zz[:m, :m]
                gram[d, k] += zz[:m, m + r_]
    gram = np.triu(gram) + np.triu(gram, 1).T + sim.block_gram(feedthrough)
    # Column scaling: the x0 regressors are transients, orders of magnitude smaller in norm
    # than the B and D regressors, and would otherwise dominate the condition number.
    scale = np.sqrt(np.diag(gram)[:k])
    scale[scale == 0.0] = 1.0
    g = gram[:k, :k] / np.outer(scale, scale)
    try:
        r = sla.cholesky(g, lower=False, check_finite=False)
        ok = method == "normal" or (method == "auto" and np.linalg.cond(r) <= _NORMAL_MAX_COND)
    except np.linalg.LinAlgError:
        ok = False
    if ok:
        theta = sla.cho_solve((r, False), gram[:k, k] / scale, check_finite=False) / scale
    else:
        r_aug = np.zeros((0, k + 1))
        col_scale = np.append(scale, 1.0)
        sim = _Regressors(a, c, z, m, _BLOCK)
        for t0 in range(0, z.shape[1], chunk):
            zc, xs, _ = sim.explicit(t0, min(t0 + chunk, z.shape[1]))
            for r_, x in enumerate(xs):
                rows = _explicit_rows(zc, x, r_, n, m, feedthrough)
                r_aug = qr_append(r_aug, rows / col_scale)
        # Same rank-revealing solver as a direct QR solve of the whole problem.
        theta = sla.lstsq(r_aug[:k, :k], r_aug[:k, k], lapack_driver="gelsy",
                          check_finite=False)[0] / scale
    bmat = theta[n:nb].reshape(m, n).T
    dmat = theta[nb:].reshape(l_, m) if feedthrough else np.zeros((l_, m))
    return bmat, dmat


def bd_gamma_perp(
    a: np.ndarray,
    c: np.ndarray,
    gperp: np.ndarray,
    psi_u: np.ndarray,
    f: int,
    m: int,
    feedthrough: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """``B, D`` from ``Gamma_perp' Psi_u = Gamma_perp' H_f(B, D)`` (no simulation).

    Parameters
    ----------
    a, c : ndarray
        Estimated ``A`` (n, n) and ``C`` (l, n).
    gperp : ndarray, shape (f l, f l - n)
        Orthogonal complement of the column space of ``Gamma_f``.
    psi_u : ndarray, shape (f l, f m)
        Regression coefficient of the future outputs on the future inputs.
    f, m : int
        Future window in samples, number of inputs.
    feedthrough : bool
        Estimate ``D``; otherwise ``D = 0``.

    Returns
    -------
    B : ndarray, shape (n, m)
    D : ndarray, shape (l, m)
    """
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
