"""``B`` and ``D`` of a state-space model whose ``A`` and ``C`` are known.

:func:`bd_least_squares`, used by the open-loop methods (:mod:`gbpipe.sysid.open_loop`):
linear least squares over the whole record. With ``A, C`` fixed,
``y[t] = C A^t x0 + sum_k C A^(t-1-k) B u[k] + D u[t]`` is linear in ``(B, D, x0)``; the
regressor of ``B[:, j]`` on output ``r`` is the state of the transposed system
``s+ = A' s + C[r]' u_j``. This is the output-error optimum for the given ``A, C`` and is
well posed for any horizon. The record is processed in pieces and only the Gram matrix of
the regressors is kept, so the memory is that of one piece, not ``N x (n m + l m + n)``;
the Gram matrix comes from block products without the per-sample regressors
(:class:`gbpipe.sysid.bd_regressors.BDRegressors`; the free response, the ``x0``
regressors, is lifted like the others, so a slowly decaying one costs nothing extra); only
a tail shorter than ``_MIN_BLOCKS`` blocks is simulated sample by sample.

For an unstable ``A`` (whose regressors would overflow) the same least squares runs in
predictor form with a gain ``K`` that makes ``A - K C`` stable:
``x+ = (A - K C) x + (B - K D) u + K y``, so ``y - C x_y`` (``x_y`` driven by ``K y``) is
linear in ``(B - K D, D, x0)`` with stable regressors. The textbook alternative,
``Gamma_perp' Psi_u = Gamma_perp' H_f(B, D)`` on the ``f`` first Markov parameters, fails
on closed-loop bench records: with a spurious empty-band pole at ``z = -4.4`` the
``C A^k`` of ``H_f`` reach 1e30 and drive ``B`` to 1e-30 (a zero FRF); written with the
SVD's ``Gamma_f`` instead, ``B`` stays finite but 50 Markov parameters leave the 5 Hz gain
(a mode at ``z = 0.999``) 36-58 dB off, against 0.2-2.6 dB here
(``tests/sysid/test_unstable_bd.py``).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from gbpipe.lti import dlsim
from gbpipe.sysid.bd_regressors import BDRegressors
from gbpipe.sysid.hankel import qr_append, records, triangular_cond

__all__ = ["bd_least_squares"]

# Samples per chunk of regressors: a few MB of temporaries, and few enough chunks that the
# per-call cost of the simulations stays small against the work per sample.
_CHUNK_SAMPLES = 1 << 17
# Block length of the block products (BDRegressors.block_gram) and the fewest blocks for
# which they pay off over the sample-by-sample regressors.
_BLOCK = 16
_MIN_BLOCKS = 64
# Sample-by-sample pieces (a record tail, or the QR pass) grow from this size (doubling) to
# _CHUNK_SAMPLES.
_FIRST_CHUNK = 1 << 12

# Largest condition number of the column-scaled regressor factor for which the normal
# equations are trusted whatever the noise. Their rounding error is ~ eps * cond^2 (1e-10 at
# 3e2 .. 2e-8 at 1e4), against eps * cond for the QR route.
_NORMAL_MAX_COND = 1e3
# Above it, the normal equations are still used when the noise dominates their rounding
# (see _normal_ok): by this factor over the statistical error, and with a residual power
# this many times the rounding floor eps cond^2 of a residual computed from the Gram matrix.
_ROUNDING_SHARE = 1e-2
_RESIDUAL_OVER_FLOOR = 1e2



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


def _normal_ok(r: np.ndarray, gram: np.ndarray, theta: np.ndarray, n_rows: int) -> bool:
    """Whether the normal-equation solution is as good as the QR one, given the noise.

    Their rounding moves ``theta`` by ~``eps cond^2`` (relative); the noise by
    ~``rho cond / sqrt(n_rows)`` (``rho``: residual over output norm). The normal equations
    are accepted when the first is ``_ROUNDING_SHARE`` of the second and ``rho^2`` is well
    above the rounding floor ``eps cond^2`` of a residual computed from the Gram matrix
    (noise-free data fail this and take the QR route), or when ``cond <= 1e3``.
    """
    eps = np.finfo(float).eps
    cond = triangular_cond(r)
    if cond <= _NORMAL_MAX_COND:
        return True
    k = gram.shape[0] - 1
    rho2 = max(gram[k, k] - theta @ gram[:k, k], 0.0) / gram[k, k]
    return bool(eps * cond <= _ROUNDING_SHARE * np.sqrt(rho2 / n_rows)
                and rho2 >= _RESIDUAL_OVER_FLOOR * eps * cond**2)


def _record_gram(a: np.ndarray, c: np.ndarray, z: np.ndarray, m: int, feedthrough: bool,
                 chunk: int) -> np.ndarray:
    """Gram matrix ``[Phi y]' [Phi y]`` of one record, columns ``[x0, B, D, y]``."""
    n, l_ = a.shape[0], c.shape[0]
    nb = n + n * m  # x0 and B columns
    k = nb + (l_ * m if feedthrough else 0)
    gram = np.zeros((k + 1, k + 1))  # upper triangle from pieces
    sim = BDRegressors(a, c, z, m, _BLOCK)
    t0, size = 0, min(_FIRST_CHUNK, chunk)
    while t0 < z.shape[1]:
        n_blocks = min(z.shape[1] - t0, chunk) // _BLOCK
        if n_blocks >= _MIN_BLOCKS:
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
    return np.triu(gram) + np.triu(gram, 1).T + sim.block_gram(feedthrough)


def _predictor_record(a_p: np.ndarray, c: np.ndarray, gain: np.ndarray, z: np.ndarray,
                      m: int) -> np.ndarray:
    """Record ``[u; y - C x_y]`` of the predictor form, ``x_y+ = (A - K C) x_y + K y``.

    ``y - C x_y`` is the output of ``x+ = (A - K C) x + (B - K D) u``, ``y = C x + D u``
    (plus the predictor-filtered noise), so the least squares of :func:`bd_least_squares`
    on it, with ``A - K C`` for ``A``, gives ``B - K D`` and ``D``.
    """
    l_ = c.shape[0]
    y_pred = dlsim(a_p, gain, c, np.zeros((l_, l_)), z[m:].T)
    return np.vstack([z[:m], z[m:] - y_pred.T])


def _record_columns(i: int, n_records: int, n: int, width: int) -> np.ndarray:
    """Columns of record ``i``'s ``[x0, B, D, y]`` in the joint ``[x0_0 .. x0_(R-1), B, D, y]``.

    Each record has its own initial state; ``B``, ``D`` and ``y`` are shared.
    """
    return np.concatenate([np.arange(i * n, (i + 1) * n),
                           n_records * n + np.arange(width - n)])


def bd_least_squares(
    a: np.ndarray,
    c: np.ndarray,
    z: np.ndarray | list[np.ndarray],
    n_inputs: int,
    feedthrough: bool,
    chunk: int = _CHUNK_SAMPLES,
    method: str = "auto",
    gain: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """``B, D`` (and a nuisance ``x0``) by least squares over the whole record, ``A, C`` fixed.

    Several records (multi-experiment data) share ``B, D`` and each has its own nuisance
    initial state: their Gram matrices fill a joint one with one ``x0`` block per record.

    The Gram matrix of the regressors and the output, ``[Phi y]' [Phi y]``, is accumulated
    chunk by chunk from products of the simulated regressors with each other and with the
    record. Its Cholesky factor is the triangular factor of ``[Phi y]`` and solves the
    problem when the (column-scaled) regressors are well conditioned; otherwise a second
    pass accumulates the factor by Householder QR (backward stable, like a direct QR solve
    of the full problem).

    Parameters
    ----------
    a : ndarray, shape (n, n)
        State matrix; stable unless ``gain`` is given (the regressors are simulations of
        the transpose of ``a - gain @ c``).
    c : ndarray, shape (l, n)
    z : ndarray, shape (m + l, N), or list of them
        Channel-scaled inputs (first ``m`` rows) and outputs, one channel per row; a list
        for several records.
    n_inputs : int
        Number of inputs ``m``.
    feedthrough : bool
        Estimate ``D``; otherwise ``D = 0``.
    chunk : int
        Largest piece of the record simulated at once, in samples.
    method : {"auto", "normal", "qr"}
        ``"normal"``: the normal equations (Cholesky of the Gram matrix); ``"qr"``: the
        Householder QR pass; ``"auto"`` (default): the normal equations when the
        column-scaled factor has ``cond <= 1e3`` (rounding ~ ``eps cond^2`` <= 2e-10) or
        when the noise moves the solution far more than their rounding does (noisy
        records: :func:`_normal_ok`), else QR.
    gain : ndarray, shape (n, l), optional
        Predictor gain ``K`` with ``A - K C`` stable, for an unstable ``A``: the least
        squares then runs in predictor form (module docstring) and ``B = (B - K D) + K D``.
        Default: output error (``K = 0``).

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
    k1 = nb + (l_ * m if feedthrough else 0)  # regressors of one record
    recs = records(z)
    if gain is not None:
        a = a - gain @ c
        recs = [_predictor_record(a, c, gain, rec, m) for rec in recs]
    n_rec = len(recs)
    k = (n_rec - 1) * n + k1  # joint regressors: one x0 block per record
    gram = np.zeros((k + 1, k + 1))
    for i, rec in enumerate(recs):
        cols = _record_columns(i, n_rec, n, k1 + 1)
        gram[np.ix_(cols, cols)] += _record_gram(a, c, rec, m, feedthrough, chunk)
    # Column scaling: the x0 regressors are transients, orders of magnitude smaller in norm
    # than the B and D regressors, and would otherwise dominate the condition number.
    scale = np.sqrt(np.diag(gram)[:k])
    scale[scale == 0.0] = 1.0
    g = gram[:k, :k] / np.outer(scale, scale)
    try:
        r = sla.cholesky(g, lower=False, check_finite=False)
    except np.linalg.LinAlgError:
        r = None
    if r is not None:
        theta = sla.cho_solve((r, False), gram[:k, k] / scale, check_finite=False) / scale
    if r is None or method == "qr" or (
        method == "auto" and not _normal_ok(r, gram, theta, sum(x.shape[1] for x in recs) * l_)
    ):
        r_aug = np.zeros((0, k + 1))
        col_scale = np.append(scale, 1.0)
        for i, rec in enumerate(recs):
            cols = _record_columns(i, n_rec, n, k1 + 1)
            sim = BDRegressors(a, c, rec, m, _BLOCK)
            for t0 in range(0, rec.shape[1], chunk):
                zc, xs, _ = sim.explicit(t0, min(t0 + chunk, rec.shape[1]))
                for r_, x in enumerate(xs):
                    rows = _explicit_rows(zc, x, r_, n, m, feedthrough)
                    if n_rec > 1:  # this record's columns of the joint problem
                        joint = np.zeros((zc.shape[1], k + 1))
                        joint[:, cols] = rows
                        rows = joint
                    rows /= col_scale  # in place: a chunk's rows are tens of MB
                    r_aug = qr_append(r_aug, rows)
        # Same rank-revealing solver as a direct QR solve of the whole problem.
        theta = sla.lstsq(r_aug[:k, :k], r_aug[:k, k], lapack_driver="gelsy",
                          check_finite=False)[0] / scale
    theta = theta[(n_rec - 1) * n:]  # drop all x0 but the last: [x0, B, D] of one record
    bmat = theta[n:nb].reshape(m, n).T
    dmat = theta[nb:].reshape(l_, m) if feedthrough else np.zeros((l_, m))
    if gain is not None:
        bmat = bmat + gain @ dmat
    return bmat, dmat
