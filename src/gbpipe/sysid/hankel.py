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

__all__ = ["hankel_gram", "window_r_factor", "lstsq_r", "RCOND"]

#: Relative cut-off of the minimum-norm least-squares solves. Noise-free records make the past
#: data rank deficient (past outputs are functions of the state and the past inputs); the cut
#: must remove those directions (size ~ eps * ||R||) and keep every genuine one.
RCOND = 1e-10

# Target size of one chunk of the Hankel matrix in bytes: large enough that LAPACK runs at
# full speed, small enough that a chunk stays in cache-friendly memory.
_CHUNK_BYTES = 4 * 2**20

# Largest cond(R) for which the Gram (normal-equations) route is accepted; see window_r_factor.
# Decimated bench records are low-passed (the band above 0.8 x Nyquist is empty), which puts
# cond(R) in the 1e4..1e7 range although their noise is far above the Gram route's rounding:
# with a 1e4 bound every such record fell back to the 2x slower QR route and gave the same
# models to the printed digit (identification stage, pbsid/moesp/n4sid, 10 pairings).
# Noise-free data (cond -> inf) still takes the backward-stable QR route.
_GRAM_MAX_COND = 1e8


def hankel_gram(z: np.ndarray, length: int) -> np.ndarray:
    """Gram matrix of the sliding-window data matrix from lagged correlations, in O(N) memory.

    Entry ``((a, i), (b, j))`` is ``sum_t z[i, t + a] z[j, t + b]`` over the
    ``N - length + 1`` windows. With ``d = b - a`` it equals the full-record correlation
    ``sum_s z[i, s] z[j, s + d]`` minus at most ``length`` edge products at each end, so the
    whole matrix costs ``channels^2 * length`` dot products of length N (not the
    ``N * (channels * length)^2`` of forming and multiplying the Hankel matrix).

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
    g = np.empty((c * L, c * L))
    a_idx = np.arange(L)
    for i in range(c):
        zi = z[i]
        for j in range(c):
            zj = z[j]
            for d in range(L):
                full = float(np.dot(zi[: n - d], zj[d:]))
                # head: s < a; tail: s >= a + n_win, i.e. the last L - 1 - (a + d) products.
                head = np.concatenate([[0.0], np.cumsum(zi[: L - d - 1] * zj[d: L - 1])])
                k = np.arange(L - d)
                tail_terms = zi[n - 1 - d - k] * zj[n - 1 - k]
                tail = np.concatenate([[0.0], np.cumsum(tail_terms)])
                a = a_idx[: L - d]
                vals = full - head[a] - tail[L - 1 - d - a]
                g[a * c + i, (a + d) * c + j] = vals
                g[(a + d) * c + j, a * c + i] = vals
    return g


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
    # One reusable Fortran-ordered buffer holds [R; chunk]; LAPACK factors it in place.
    buf = np.empty((width + chunk_rows, width), order="F")
    for t0 in range(0, n_win, chunk_rows):
        nt = min(chunk_rows, n_win - t0)
        k = r.shape[0]
        if k + nt == buf.shape[0]:
            m = buf
        else:
            m = np.empty((k + nt, width), order="F")
        m[:k] = r
        for j in range(width):
            s = t0 + lags[j]
            m[k:, j] = z[chans[j], s: s + nt]
        qr, _, _, info = lapack.dgeqrf(m, overwrite_a=True)
        if info != 0:  # pragma: no cover - LAPACK argument errors only
            raise RuntimeError(f"LAPACK dgeqrf failed with info={info}")
        r = np.triu(qr[: min(width, k + nt)])
    if r.shape[0] < width:
        r = np.vstack([r, np.zeros((width - r.shape[0], width))])
    return r / np.sqrt(n_win), n_win


def lstsq_r(a: np.ndarray, b: np.ndarray, regularization: float = 0.0) -> np.ndarray:
    """Minimum-norm solution of ``min ||a @ x - b||^2 + regularization * ||x||^2``.

    ``a`` and ``b`` are small (rows of an ``R`` factor times coefficient matrices).
    """
    if regularization > 0.0:
        a = np.vstack([a, np.sqrt(regularization) * np.eye(a.shape[1])])
        b = np.vstack([b, np.zeros((a.shape[1], b.shape[1]))])
    x, *_ = sla.lstsq(a, b, cond=RCOND, lapack_driver="gelsd", check_finite=False)
    return x
