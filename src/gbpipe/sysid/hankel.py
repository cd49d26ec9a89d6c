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

from gbpipe.errors import ConfigError

__all__ = ["lagged_products", "hankel_gram", "window_r_factor", "qr_append", "lstsq_r",
           "triangular_cond", "records", "n_windows", "RCOND"]

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

# Ridge of the Gram route, per sqrt(window) and relative to the (unit, channel-scaled)
# signal power: ~10x the rounding of the lagged products (which grows like eps sqrt(N)), so
# the Cholesky factor exists even for a deeply low-passed record (an empty band makes the
# Gram matrix singular to working precision). The factor is then that of the data plus white
# noise of power ``ridge``: ~-125 dB at N = 6e4, ~-115 dB at N = 1e6.
_RIDGE_PER_SQRT_N = 10.0 * np.finfo(float).eps
# The ridge is accepted when the noise of the predicted outputs (their regression residual)
# has at least this many times its power, so that it moves the estimates by far less than
# the noise does; noise-free records fail the test and take the QR route.
_NOISE_OVER_RIDGE = 1e4


def records(z: np.ndarray | list[np.ndarray]) -> list[np.ndarray]:
    """The records of ``z``: one array (channels, N) or a list of them (multi-experiment)."""
    return [z] if isinstance(z, np.ndarray) else list(z)


def n_windows(z: np.ndarray | list[np.ndarray], length: int) -> int:
    """Number of windows of ``length`` samples inside the records (none straddles two)."""
    return sum(r.shape[1] - length + 1 for r in records(z))


def triangular_cond(r: np.ndarray) -> float:
    """1-norm condition number estimate of an upper-triangular matrix (LAPACK ``dtrcon``).

    O(n^2), against the O(n^3) SVD of :func:`numpy.linalg.cond`; within a small factor of
    the exact value, which is all the route decisions need. ``inf`` when singular.
    """
    if r.size == 0:
        return 1.0
    rcond, info = lapack.dtrcon(np.asfortranarray(r), norm="1", uplo="U", diag="N")
    return float("inf") if info != 0 or rcond <= 0.0 else 1.0 / float(rcond)


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


def hankel_gram(z: np.ndarray | list[np.ndarray], length: int) -> np.ndarray:
    """Gram matrix of the sliding-window data matrix from lagged correlations, in O(N) memory.

    For a list of records (multi-experiment data) the Gram matrices of the records add up:
    no window straddles two records.

    Entry ``((a, i), (b, j))`` is ``sum_t z[i, t + a] z[j, t + b]`` over the
    ``N - length + 1`` windows. With ``d = b - a`` it equals the full-record correlation
    ``sum_s z[i, s] z[j, s + d]`` (:func:`lagged_products`) minus the ``a`` products before
    the first window and the ``length - 1 - a - d`` after the last one, so the whole matrix
    costs ``2 channels^2 length N`` flops in matrix products (not the
    ``N (channels length)^2`` of forming and multiplying the Hankel matrix).

    Parameters
    ----------
    z : ndarray, shape (channels, N), or list of them
    length : int
        Window length ``L`` in samples.

    Returns
    -------
    ndarray, shape (channels * L, channels * L)
        Indexed ``lag * channels + channel``; not normalised.
    """
    if not isinstance(z, np.ndarray):
        return sum(hankel_gram(rec, length) for rec in records(z))
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
    z: np.ndarray | list[np.ndarray],
    length: int,
    columns: np.ndarray,
    chunk_rows: int | None = None,
    method: str = "auto",
    gram: np.ndarray | None = None,
    n_predicted: int = 0,
) -> tuple[np.ndarray, int]:
    """Triangular factor of the sliding-window data matrix, without forming that matrix.

    Row ``t`` of the data matrix ``W`` is ``z[ch_j, t + lag_j]`` for the columns
    ``(lag_j, ch_j)``, ``t = 0 .. N - length`` (for a list of records: the windows of every
    record, none straddling two). Returns upper-triangular ``R`` with
    ``W.T @ W / n_windows == R.T @ R``.

    Two routes, chosen by ``method``:

    * ``"gram"``: Gram matrix from lagged correlations (:func:`hankel_gram`), then Cholesky.
      Fastest, but squaring the data doubles the condition number's exponent.
    * ``"qr"``: tall-skinny Householder QR over chunks of windows: each chunk of the Hankel
      matrix is stacked under the running ``R`` and re-factored. Backward stable even for
      rank-deficient (noise-free) data.
    * ``"ridge"``: the Gram route when its factor exists with ``cond(R) <= 1e8``, else the
      Gram route with the ridge below, whatever the noise (QR only when even that fails).
      For records known to carry noise or process noise that may lie below the check of
      ``"auto"`` (the identify stage's decimated bench records: docs/sysid.md).
    * ``"auto"`` (default): the Gram route when its factor exists with ``cond(R) <= 1e8``;
      else (e.g. a record low-passed with a deep stop band: its Gram matrix is singular to
      working precision) the Gram route with a ridge of ``10 eps sqrt(N)`` (white noise at
      ~-120 dB) when the ``n_predicted`` last columns (the outputs the method regresses on
      the others) leave a residual with ``1e4`` times that power, i.e. when the record's
      own noise dwarfs the ridge; else QR (noise-free data).

    Parameters
    ----------
    z : ndarray, shape (channels, N), or list of them
        Signals, one channel per row (C-contiguous so each row slice is contiguous).
    length : int
        Window length in samples.
    columns : ndarray of int, shape (width, 2)
        ``(lag, channel)`` pair of each column, in the order wanted for the factor.
    chunk_rows : int, optional
        Windows per QR chunk; by default chosen so one chunk is about 4 MiB.
    method : {"auto", "ridge", "gram", "qr"}
    gram : ndarray, optional
        ``hankel_gram(z, length)`` when the caller already has it (the excitation check
        uses it first); computed here otherwise.
    n_predicted : int
        Number of trailing columns whose regression residual measures the noise (0: the
        ridge route is not tried).

    Returns
    -------
    R : ndarray, shape (width, width)
        Upper-triangular factor, normalised by ``sqrt(n_windows)``.
    n_windows : int
    """
    n_win = n_windows(z, length)
    width = columns.shape[0]
    lags = columns[:, 0]
    chans = columns[:, 1]
    if method not in ("auto", "ridge", "gram", "qr"):
        raise ConfigError("factor", f"unknown route {method!r}; use auto, ridge, gram or qr")
    if method in ("auto", "ridge", "gram"):
        recs = records(z)
        idx = lags * recs[0].shape[0] + chans
        if gram is None:
            gram = hankel_gram(recs, length)
        g = gram[np.ix_(idx, idx)] / n_win
        try:
            r = sla.cholesky(g, lower=False, check_finite=False)
        except np.linalg.LinAlgError:
            r = None
        if r is not None and (method == "gram" or triangular_cond(r) <= _GRAM_MAX_COND):
            return r, n_win
        if method == "ridge" or (method == "auto" and n_predicted > 0):
            r = _ridge_factor(g, n_win, n_predicted if method == "auto" else 0)
            if r is not None:
                return r, n_win
    if chunk_rows is None:
        chunk_rows = max(4 * width, _CHUNK_BYTES // (8 * width))
    r = np.zeros((0, width))
    for rec in records(z):
        n_rec = rec.shape[1] - length + 1
        block = np.empty((min(chunk_rows, n_rec), width), order="F")  # filled by columns
        for t0 in range(0, n_rec, chunk_rows):
            nt = min(chunk_rows, n_rec - t0)
            for j in range(width):
                s = t0 + lags[j]
                block[:nt, j] = rec[chans[j], s: s + nt]
            r = qr_append(r, block[:nt])
    if r.shape[0] < width:
        r = np.vstack([r, np.zeros((width - r.shape[0], width))])
    return r / np.sqrt(n_win), n_win


def _ridge_factor(g: np.ndarray, n_win: int, n_predicted: int) -> np.ndarray | None:
    """Cholesky factor of ``g + ridge I``, or None when the noise of the ``n_predicted``
    last columns does not dwarf the ridge (``n_predicted = 0``: no such check).

    Not the smallest ridge that makes the rounded Gram matrix positive definite: on
    low-passed stage-size records (``benchmarks/sysid.py --stage-size``, 120 dB stop band)
    ``10 eps sqrt(N)`` gave FRFs closer to the truth on average than 1/1000 of it (which
    damps the empty-band directions less) and than the QR route.
    """
    ridge = _RIDGE_PER_SQRT_N * np.sqrt(n_win) * float(np.max(np.diag(g)))
    try:
        r = sla.cholesky(g + ridge * np.eye(g.shape[0]), lower=False, check_finite=False)
    except np.linalg.LinAlgError:
        return None
    if n_predicted == 0:  # no noise check (route "ridge")
        return r
    k0 = g.shape[0] - n_predicted
    # Residual power of each predicted column after regression on every column before it.
    resid = np.array([r[k0: j + 1, j] @ r[k0: j + 1, j] for j in range(k0, g.shape[0])])
    return r if np.all(resid >= _NOISE_OVER_RIDGE * ridge) else None


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

    ``a`` and ``b`` are small (rows of an ``R`` factor times coefficient matrices). A square
    upper-triangular ``a`` whose condition number (1-norm estimate, within a small factor of
    the 2-norm value) is below ``0.1 / RCOND`` has nothing for the minimum-norm cut to
    remove, so it is solved by back substitution (O(k^2)) instead of the SVD-based
    ``gelsd`` (O(k^3)); both give the same solution to rounding.
    """
    if regularization > 0.0:
        a = np.vstack([a, np.sqrt(regularization) * np.eye(a.shape[1])])
        b = np.vstack([b, np.zeros((a.shape[1], b.shape[1]))])
    elif (a.shape[0] == a.shape[1] and not np.any(np.tril(a, -1))
          and triangular_cond(a) <= 0.1 / RCOND):
        return sla.solve_triangular(a, b, lower=False, check_finite=False)
    x, *_ = sla.lstsq(a, b, cond=RCOND, lapack_driver="gelsd", check_finite=False)
    return x
