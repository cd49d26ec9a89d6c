"""Data products of the subspace methods in O(N) memory: Gram matrix and triangular factor.

Every method reduces the record to the triangular factor ``R`` of a block-Hankel data matrix
whose rows are sliding windows of the (scaled) signals. ``R`` comes from the Gram matrix of
lagged correlations (:func:`hankel_gram`, then Cholesky) or is accumulated chunk by chunk
with Householder QR (a "tall-skinny QR"), so the memory cost is that of the record itself
plus one chunk, and never that of the full Hankel matrix (``windows x columns``) or of an
``N x N`` projection. Every later step works on ``R`` only: a signal that is a linear
combination ``W @ c`` of window columns has ``||W @ c|| = ||R @ c||`` because ``W = Q @ R``
with orthonormal ``Q``, so least-squares problems over the record become small problems
over ``R`` (:func:`lstsq_r`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from scipy.linalg import lapack

__all__ = ["lagged_products", "hankel_gram", "window_r_factor", "qr_append", "lstsq_r", "RCOND"]

#: Relative cut-off of the minimum-norm least-squares solves. Noise-free records make the past
#: data rank deficient (past outputs are functions of the state and the past inputs); the cut
#: must remove those directions (size ~ eps * ||R||) and keep every genuine one.
RCOND = 1e-10

# Target size of one chunk of the Hankel matrix in bytes: large enough that LAPACK runs at
# full speed, small enough that a chunk stays in cache-friendly memory.
_CHUNK_BYTES = 4 * 2**20
# Size of one run of blocks in lagged_products: about the size of a core's L2 cache.
_RUN_BYTES = 2**20

# Largest cond(R) for which the Gram (normal-equations) route is accepted; see window_r_factor.
# Decimated bench records are low-passed (the band above 0.8 x Nyquist is empty), which puts
# cond(R) in the 1e4..1e7 range although their noise is far above the Gram route's rounding:
# with a 1e4 bound every such record fell back to the 2x slower QR route and gave the same
# models to the printed digit (identification stage, pbsid/moesp/n4sid, 10 pairings).
# Noise-free data (cond -> inf) still takes the backward-stable QR route.
_GRAM_MAX_COND = 1e8


def lagged_products(z: np.ndarray, length: int) -> np.ndarray:
    """Full-record lagged products ``out[d, i, j] = sum_s z[i, s] z[j, s + d]``, ``d < length``.

    The record is cut into blocks of ``L = length`` samples, ``Z_i`` (blocks x L) per
    channel. A pair at lag ``d < L`` lies in one block or in two neighbouring ones, so
    every product is in ``Z_i' Z_j`` (same block, on its ``d``-th diagonal) or in
    ``Z_i[:-1]' Z_j[1:]`` (next block, diagonal ``d - L``). Two matrix products per pair of
    channels replace ``L`` dot products over the record: the same arithmetic, but run by
    BLAS from cache instead of streaming the record ``L`` times.

    Parameters
    ----------
    z : ndarray, shape (channels, N)
    length : int
        Number of lags ``L``.

    Returns
    -------
    ndarray, shape (L, channels, channels)
    """
    c, n = z.shape
    L = length
    nb = n // L
    e = nb * L
    zb = z[:, :e].reshape(c, nb, L)
    same = np.zeros((c, c, L, L))  # same[i, j] = Z_i' Z_j (i <= j)
    nxt = np.zeros((c, c, L, L))  # nxt[i, j] = Z_i[:-1]' Z_j[1:]
    # Runs of blocks of about _RUN_BYTES: each run is read from memory once and all
    # channel pairs are multiplied while it is in cache.
    step = max(1, _RUN_BYTES // (8 * c * L))
    for b0 in range(0, nb, step):
        b1 = min(b0 + step, nb)
        run, run_next = zb[:, b0:b1], zb[:, b0 + 1: b1 + 1]
        k = run_next.shape[1]  # the last block has no next one
        for i in range(c):
            for j in range(c):
                if j >= i:  # the same-block product of (j, i) is that of (i, j) transposed
                    same[i, j] += run[i].T @ run[j]
                nxt[i, j] += run[i, :k].T @ run_next[j]
    # Diagonal d of a block product: (row, col) pairs with col - row = d (same block) or
    # col - row = d - L (next block); bincount sums each diagonal in one call.
    same_r, same_c = np.triu_indices(L)
    next_r, next_c = np.tril_indices(L, -1)
    out = np.zeros((L, c, c))
    for i in range(c):
        for j in range(c):
            sm = same[i, j] if j >= i else same[j, i].T
            out[:, i, j] = (
                np.bincount(same_c - same_r, sm[same_r, same_c], minlength=L)
                + np.bincount(L + next_c - next_r, nxt[i, j][next_r, next_c], minlength=L)
            )
    # Pairs whose later sample lies beyond the last full block: s + d >= e.
    for d in range(L):
        lo = max(e - d, 0)
        if lo < n - d:
            out[d] += z[:, lo: n - d] @ z[:, lo + d: n].T
    return out


def hankel_gram(z: np.ndarray, length: int) -> np.ndarray:
    """Gram matrix of the sliding-window data matrix from lagged correlations, in O(N) memory.

    Entry ``((a, i), (b, j))`` is ``sum_t z[i, t + a] z[j, t + b]`` over the
    ``N - length + 1`` windows. With ``d = b - a`` it equals the full-record correlation
    ``sum_s z[i, s] z[j, s + d]`` (:func:`lagged_products`) minus the ``a`` products before
    the first window and the ``length - 1 - a - d`` after the last one, so the whole matrix
    costs ``2 channels^2 length N`` flops in matrix products (not the
    ``N (channels length)^2`` of forming and multiplying the Hankel matrix).

    Parameters
    ----------
    z : ndarray, shape (channels, N)
    length : int
        Window length ``L`` in samples.

    Returns
    -------
    ndarray, shape (channels * L, channels * L)
        Indexed ``lag * channels + channel``; not normalised.
    """
    c, n = z.shape
    L = length
    if n < 2 * L:  # too short for the edge bookkeeping below: form the windows
        w = np.lib.stride_tricks.sliding_window_view(z, L, axis=1)  # (c, n_win, L)
        w = w.transpose(1, 2, 0).reshape(n - L + 1, L * c)
        return w.T @ w
    full = lagged_products(z, L)
    # head[a, d, i, j] = sum_{s < a} z[i, s] z[j, s + d]
    zh = z[:, : 2 * L - 1]
    win_h = np.lib.stride_tricks.sliding_window_view(zh, L, axis=1)  # [j, s, d] = z[j, s + d]
    prod_h = zh[:, :L].T[:, None, :, None] * win_h.transpose(1, 2, 0)[:, :, None, :]
    head = np.concatenate([np.zeros((1, L, c, c)), np.cumsum(prod_h, axis=0)[:-1]])
    # tail[q, d, i, j] = sum of the q last products of lag d:
    # sum_{p < q} z[i, n - 1 - d - p] z[j, n - 1 - p]
    zr = z[:, n - 2 * L + 1:][:, ::-1]  # zr[:, k] = z[:, n - 1 - k]
    win_t = np.lib.stride_tricks.sliding_window_view(zr, L, axis=1)  # [i, p, d] = zr[i, p + d]
    prod_t = win_t.transpose(1, 2, 0)[:, :, :, None] * zr[:, :L].T[:, None, None, :]
    tail = np.concatenate([np.zeros((1, L, c, c)), np.cumsum(prod_t, axis=0)[:-1]])
    a, d = np.nonzero(np.add.outer(np.arange(L), np.arange(L)) < L)
    vals = full[d] - head[a, d] - tail[L - 1 - a - d, d]  # (pairs, c, c)
    g = np.empty((L, c, L, c))
    g[a, :, a + d, :] = vals
    g[a + d, :, a, :] = vals.transpose(0, 2, 1)
    return g.reshape(L * c, L * c)


def window_r_factor(
    z: np.ndarray,
    length: int,
    columns: np.ndarray,
    chunk_rows: int | None = None,
    method: str = "auto",
    gram: np.ndarray | None = None,
) -> tuple[np.ndarray, int]:
    """Triangular factor of the sliding-window data matrix, without forming that matrix.

    Row ``t`` of the data matrix ``W`` is ``z[ch_j, t + lag_j]`` for the columns
    ``(lag_j, ch_j)``, ``t = 0 .. N - length``. Returns upper-triangular ``R`` with
    ``W.T @ W / n_windows == R.T @ R``.

    Two routes, chosen by ``method``:

    * ``"gram"``: Gram matrix from lagged correlations (:func:`hankel_gram`), then Cholesky.
      Fastest, but squaring the data doubles the condition number's exponent.
    * ``"qr"``: tall-skinny Householder QR over chunks of windows: each chunk of the Hankel
      matrix is stacked under the running ``R`` and re-factored. Backward stable even for
      rank-deficient (noise-free) data.
    * ``"auto"`` (default): the Gram route when its factor has ``cond(R) <= 1e8`` (the
      rounding it adds, ~``eps * cond^2``, is then below the noise of measured or decimated
      records), else QR.

    Parameters
    ----------
    z : ndarray, shape (channels, N)
        Signals, one channel per row (C-contiguous so each row slice is contiguous).
    length : int
        Window length in samples.
    columns : ndarray of int, shape (width, 2)
        ``(lag, channel)`` pair of each column, in the order wanted for the factor.
    chunk_rows : int, optional
        Windows per QR chunk; by default chosen so one chunk is about 4 MiB.
    method : {"auto", "gram", "qr"}
    gram : ndarray, optional
        ``hankel_gram(z, length)`` when the caller already has it (the excitation check
        uses it first); computed here otherwise.

    Returns
    -------
    R : ndarray, shape (width, width)
        Upper-triangular factor, normalised by ``sqrt(n_windows)``.
    n_windows : int
    """
    n = z.shape[1]
    n_win = n - length + 1
    width = columns.shape[0]
    lags = columns[:, 0]
    chans = columns[:, 1]
    if method in ("auto", "gram"):
        idx = lags * z.shape[0] + chans
        if gram is None:
            gram = hankel_gram(z, length)
        g = gram[np.ix_(idx, idx)] / n_win
        try:
            r = sla.cholesky(g, lower=False, check_finite=False)
        except np.linalg.LinAlgError:
            r = None
        if r is not None and (method == "gram" or np.linalg.cond(r) <= _GRAM_MAX_COND):
            return r, n_win
    if chunk_rows is None:
        chunk_rows = max(4 * width, _CHUNK_BYTES // (8 * width))
    r = np.zeros((0, width))
    block = np.empty((min(chunk_rows, n_win), width), order="F")  # filled by columns
    for t0 in range(0, n_win, chunk_rows):
        nt = min(chunk_rows, n_win - t0)
        for j in range(width):
            s = t0 + lags[j]
            block[:nt, j] = z[chans[j], s: s + nt]
        r = qr_append(r, block[:nt])
    if r.shape[0] < width:
        r = np.vstack([r, np.zeros((width - r.shape[0], width))])
    return r / np.sqrt(n_win), n_win


def qr_append(r: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Upper-triangular factor of ``[r; rows]`` (Householder QR, LAPACK ``dgeqrf``).

    One step of a tall-skinny QR: applied chunk after chunk, it gives the factor of all the
    rows seen, ``R' R = sum of rows' rows``, in the memory of one chunk.

    Parameters
    ----------
    r : ndarray, shape (k, w)
        Factor so far (``k <= w`` rows; ``k = 0`` to start).
    rows : ndarray, shape (nt, w)
        New rows.

    Returns
    -------
    ndarray, shape (min(w, k + nt), w)
    """
    k, w = r.shape
    # One Fortran-ordered buffer holds [R; rows]; LAPACK factors it in place.
    m = np.empty((k + rows.shape[0], w), order="F")
    m[:k] = r
    m[k:] = rows
    qr, _, _, info = lapack.dgeqrf(m, overwrite_a=True)
    if info != 0:  # pragma: no cover - LAPACK argument errors only
        raise RuntimeError(f"LAPACK dgeqrf failed with info={info}")
    return np.triu(qr[: min(w, m.shape[0])])


def lstsq_r(a: np.ndarray, b: np.ndarray, regularization: float = 0.0) -> np.ndarray:
    """Minimum-norm solution of ``min ||a @ x - b||^2 + regularization * ||x||^2``.

    ``a`` and ``b`` are small (rows of an ``R`` factor times coefficient matrices).
    """
    if regularization > 0.0:
        a = np.vstack([a, np.sqrt(regularization) * np.eye(a.shape[1])])
        b = np.vstack([b, np.zeros((a.shape[1], b.shape[1]))])
    x, *_ = sla.lstsq(a, b, cond=RCOND, lapack_driver="gelsd", check_finite=False)
    return x
