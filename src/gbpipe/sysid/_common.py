"""Shared numerics of the subspace methods: input checks, channel scaling, chunked data products.

Every method reduces the record to the triangular factor ``R`` of a block-Hankel data matrix
whose rows are sliding windows of the (scaled) signals. ``R`` is accumulated chunk by chunk
with Householder QR (a "tall-skinny QR"), so the memory cost is that of the record itself plus
one chunk, and never that of the full Hankel matrix (``windows x columns``) or of an ``N x N``
projection. Every later step works on ``R`` only: a signal that is a linear combination
``W @ c`` of window columns has ``||W @ c|| = ||R @ c||`` because ``W = Q @ R`` with orthonormal
``Q``, so least-squares problems over the record become small problems over ``R``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from scipy.linalg import lapack

__all__ = [
    "PreparedData",
    "prepare",
    "hankel_gram",
    "window_r_factor",
    "lstsq_r",
    "select_order",
    "check_order",
    "kalman_gain",
    "stable_predictor_gain",
]

# Relative cut-off of the minimum-norm least-squares solves. Noise-free records make the past
# data rank deficient (past outputs are functions of the state and the past inputs); the cut
# must remove those directions (size ~ eps * ||R||) and keep every genuine one.
_RCOND = 1e-10

# Target size of one chunk of the Hankel matrix in bytes: large enough that LAPACK runs at
# full speed, small enough that a chunk stays in cache-friendly memory.
_CHUNK_BYTES = 4 * 2**20

# Largest cond(R) for which the Gram (normal-equations) route is accepted; see window_r_factor.
# Decimated bench records are low-passed (the band above 0.8 x Nyquist is empty), which puts
# cond(R) in the 1e4..1e7 range although their noise is far above the Gram route's rounding:
# with the old 1e4 bound every such record fell back to the 2x slower QR route and gave the
# same models to the printed digit (identification stage, pbsid/moesp/n4sid, 10 pairings).
# Noise-free data (cond -> inf) still takes the backward-stable QR route.
_GRAM_MAX_COND = 1e8


@dataclass(frozen=True)
class PreparedData:
    """Validated, scaled copies of a record.

    Attributes
    ----------
    z : ndarray, shape (m + l, N)
        Scaled inputs (first ``m`` rows) and outputs (last ``l`` rows), one channel per row.
    u_scale, y_scale : ndarray
        Root-mean-square value of each raw input / output channel (the scaling divisors).
    n_samples, n_inputs, n_outputs : int
    """

    z: np.ndarray
    u_scale: np.ndarray
    y_scale: np.ndarray
    n_samples: int
    n_inputs: int
    n_outputs: int


def as_2d(x: object, name: str) -> np.ndarray:
    """Return ``x`` as a float array of shape (samples, channels) (a view when possible)."""
    arr = np.asarray(x)
    if arr.dtype == object or not (
        np.issubdtype(arr.dtype, np.number) or arr.dtype == np.bool_
    ):
        raise TypeError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    if np.iscomplexobj(arr):
        raise TypeError(f"{name} must be real-valued; pass the real signal, not a spectrum")
    arr = arr.astype(float, copy=False)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise ValueError(
            f"{name} must have shape (samples,) or (samples, channels), got shape {arr.shape}"
        )
    return arr


def check_finite(arr: np.ndarray, name: str) -> None:
    """Raise ``ValueError`` naming the first NaN/inf sample of ``arr``."""
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = np.argwhere(bad)[0]
        raise ValueError(
            f"{name} contains NaN or inf (first at sample {idx[0]}, channel {idx[1]}); "
            "remove or interpolate those samples before identification"
        )


def prepare(
    u: object, y: object, *, min_samples: int, window_desc: str
) -> PreparedData:
    """Validate ``u``/``y`` and return scaled copies (the caller's arrays are never touched).

    Parameters
    ----------
    u, y : array_like, shape (N,) or (N, channels)
        Input and output records, same number of samples, finite.
    min_samples : int
        Smallest record length the chosen windows can use.
    window_desc : str
        Text naming the windows, used in the "record too short" message.

    Returns
    -------
    PreparedData

    Raises
    ------
    ValueError
        NaN/inf, mismatched lengths, too-short record or a constant (all-zero) channel.
    """
    ua = as_2d(u, "u")
    ya = as_2d(y, "y")
    if ua.shape[0] != ya.shape[0]:
        raise ValueError(
            f"u and y must have the same number of samples (axis 0); got u: {ua.shape[0]}, "
            f"y: {ya.shape[0]}. Pass records of equal length (time along axis 0)"
        )
    n = ua.shape[0]
    if n < min_samples:
        raise ValueError(
            f"record too short: {n} samples, but {window_desc} need at least {min_samples}; "
            "use a longer record or smaller windows"
        )
    check_finite(ua, "u")
    check_finite(ya, "y")
    # Channel scaling: each channel divided by its RMS value, so that badly scaled units
    # (e.g. N*m against rad/s) do not steer the SVD and the rank decisions.
    u_scale = np.sqrt(np.mean(ua * ua, axis=0))
    y_scale = np.sqrt(np.mean(ya * ya, axis=0))
    for name, sc in (("u", u_scale), ("y", y_scale)):
        zero = np.flatnonzero(sc == 0.0)
        if zero.size:
            raise ValueError(
                f"{name} channel {zero[0]} is identically zero; an identification needs every "
                "channel to carry signal: drop that channel"
            )
    z = np.empty((ua.shape[1] + ya.shape[1], n))
    np.divide(ua.T, u_scale[:, None], out=z[: ua.shape[1]])
    np.divide(ya.T, y_scale[:, None], out=z[ua.shape[1]:])
    return PreparedData(z, u_scale, y_scale, n, ua.shape[1], ya.shape[1])


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
    * ``"auto"`` (default): the Gram route when its factor has ``cond(R) <= 1e4`` (the
      rounding it adds, ~``eps * cond^2``, is then far below any noise in the data), else QR.

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
        g = hankel_gram(z, length)[np.ix_(idx, idx)] / n_win
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
    x, *_ = sla.lstsq(a, b, cond=_RCOND, lapack_driver="gelsd", check_finite=False)
    return x


def select_order(s: np.ndarray, max_order: int) -> int:
    """Model order from singular values: the last large gap above the noise floor.

    The log-spectrum of singular values drops at the true order onto a flat noise floor.
    Candidates are the orders whose gap ``log(s[n-1] / s[n])`` is at least half the largest
    gap; the highest candidate is taken, so that a weak second resonance (a smaller gap
    inside the signal part) is not cut off in favour of the strongest one.

    Parameters
    ----------
    s : ndarray
        Singular values, descending.
    max_order : int
        Largest admissible order.

    Returns
    -------
    int
    """
    s = np.asarray(s, dtype=float)
    top = min(max_order, s.size - 1)
    if top < 1:
        return max(1, min(max_order, s.size))
    floor = s[0] * 1e-13  # values at round-off level count as zero
    ls = np.log(np.maximum(s[: top + 1], floor))
    gaps = ls[:-1] - ls[1:]  # gaps[i] = log(s[i] / s[i + 1]): order i + 1
    best = float(gaps.max())
    cand = np.flatnonzero(gaps >= 0.5 * best)
    return int(cand[-1] + 1)


def check_order(order: object, max_order: int, what: str) -> int | None:
    """Validate ``order`` (int or ``"auto"``); return it, or None for ``"auto"``."""
    if isinstance(order, str):
        if order != "auto":
            raise ValueError(f"order must be a positive integer or 'auto', got {order!r}")
        return None
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)):
        raise TypeError(f"order must be a positive integer or 'auto', got {order!r}")
    if order < 1:
        raise ValueError(f"order must be >= 1, got {order}")
    if order > max_order:
        raise ValueError(
            f"order={order} is larger than the windows allow ({what} give at most "
            f"{max_order}); lower the order or lengthen the windows"
        )
    return int(order)


def check_window(value: object, name: str, minimum: int = 1) -> int:
    """Validate a window length (positive integer)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer number of samples, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum} samples, got {value}")
    return int(value)


def check_dt(dt: object) -> float:
    """Validate the sample time in seconds."""
    try:
        val = float(dt)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise TypeError(f"dt must be a positive number of seconds, got {dt!r}") from None
    if not np.isfinite(val) or val <= 0:
        raise ValueError(f"dt must be a positive, finite number of seconds, got {dt!r}")
    return val


def _psd_part(m: np.ndarray) -> np.ndarray:
    m = 0.5 * (m + m.T)
    w, v = np.linalg.eigh(m)
    return (v * np.maximum(w, 0.0)) @ v.T


def kalman_gain(
    a: np.ndarray, c: np.ndarray, q: np.ndarray, r: np.ndarray, s: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """Steady-state Kalman (innovation-form) gain and innovation covariance.

    Model ``x+ = A x + w``, ``y = C x + v`` with ``cov([w; v]) = [[Q, S], [S', R]]``.
    Returns ``(K, C P C' + R)`` or ``None`` when the Riccati equation has no stabilising
    solution.
    """
    n, l_ = a.shape[0], c.shape[0]
    full = _psd_part(np.block([[q, s], [s.T, r]]))
    q, s, r = full[:n, :n], full[:n, n:], full[n:, n:]
    # A tiny floor keeps R invertible when an output is (numerically) noise-free.
    r = r + 1e-12 * max(np.trace(r) / l_, 1e-300) * np.eye(l_) + 1e-300 * np.eye(l_)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            p = sla.solve_discrete_are(a.T, c.T, q, r, s=s)
    except (np.linalg.LinAlgError, ValueError):
        return None
    if not np.all(np.isfinite(p)):
        return None
    re = c @ p @ c.T + r
    k = np.linalg.solve(re.T, (a @ p @ c.T + s).T).T
    if np.max(np.abs(np.linalg.eigvals(a - k @ c))) >= 1.0:
        return None
    return k, 0.5 * (re + re.T)


def stable_predictor_gain(
    a: np.ndarray, c: np.ndarray, k: np.ndarray, q: np.ndarray, r: np.ndarray, s: np.ndarray
) -> np.ndarray:
    """Return ``k`` if ``A - K C`` is stable, otherwise a Kalman gain that makes it stable.

    The fall-back chain is the Kalman gain of the estimated covariances, then that of
    regularised covariances (``Q + I``, which has a stabilising solution whenever ``(A, C)``
    is detectable).

    Raises
    ------
    RuntimeError
        ``(A, C)`` is not detectable, so no gain can stabilise the predictor.
    """
    if np.max(np.abs(np.linalg.eigvals(a - k @ c))) < 1.0:
        return k
    for q_try in (q, q + np.eye(a.shape[0]) * max(np.trace(q) / a.shape[0], 1.0)):
        res = kalman_gain(a, c, q_try, r, s)
        if res is not None:
            return res[0]
    raise RuntimeError(
        "no stable predictor exists: (A, C) is not detectable; try another order"
    )
