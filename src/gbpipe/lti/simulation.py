"""Exact simulation of discrete and zero-order-hold sampled LTI state-space systems.

One algorithm, exact for any state matrix (defective, ill-conditioned eigenvectors,
integrators): no eigen-decomposition. Time alignment (as ``scipy.signal.dlsim`` and
``scipy.signal.lsim(..., interp=False)``)::

    x[0]   = x0
    x[k+1] = Ad x[k] + Bd u[k]            (u[k] held over [k dt, (k+1) dt))
    y[k]   = C x[k] + D u[k]              (sample k is at time k dt)

Block method: with the powers ``Ad^j`` (j ≤ L) computed once, the outputs of a block of L
samples starting at ``x_b`` are ``Y_b = O x_b + T U_b`` (``O`` the observability matrix,
``T`` the block-Toeplitz matrix of Markov parameters), evaluated for many blocks in one
matrix product. The block-start states obey ``x_{b+1} = Ad^L x_b + R U_b``, advanced in
segments of blocks that all step together (see :func:`_block_starts`), so no Python loop
runs over samples or blocks.

Accuracy: no eigen-decomposition, so neither defective nor ill-conditioned eigenvectors
enter. The powers are formed in extended precision and rounded once, and the top-level
loop runs in extended precision, so no power of ``Ad`` accumulates rounding; what is left
is the rounding of the matrix products, of the size of the float64 sample-by-sample
recursion's own or below (benchmarks/simulate.py: Jordan blocks and integrators 0.3-1
times it; on the bench, whose torques are differences of absolute angles, 4e-10 against
the float64 recursion's 3e-9).

Strongly non-normal ``Ad`` (transient growth: ``||Ad^j||`` far above ``||Ad||``) breaks
both premises: the extended-precision chain ``Ad^(j+1) = Ad Ad^j`` cancels (its entries
are far smaller than those of ``|Ad| |Ad^j|``), and the float64 products by the block
powers amplify their rounding. Such systems (cancellation factor above that of a normal
matrix, see :func:`_cancels`) take the precise path: ``Ad^L``, ``C Ad^j`` and
``Ad^j Bd`` exact to the last bit of ``np.longdouble`` (:mod:`gbpipe.lti.exact_powers`)
and one extended-precision loop over all block starts, without the segments: below 0.01
times the float64 recursion's error on eigenvector condition 1e5-1e6 and on near-repeated
modes (benchmarks/simulate.py), at a few times the fast path's cost.
See docs/architecture.md, "Physics".
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.signal import cont2discrete

from gbpipe.lti.exact_powers import exact_krylov, exact_power
from gbpipe.memo import ArrayMemo, array_key

__all__ = ["dlsim", "lsim"]

# Samples per processing chunk: bounds the temporaries to a few tens of MB.
_CHUNK_SAMPLES = 1 << 16
# Longest run of block-start states looped over in extended precision (at least two
# segments); longer runs are cut into segments of _SEGMENT blocks (see _block_starts).
_MIN_LIFTED = 64
_SEGMENT = 16
# Lifted matrices of the most recent systems: a validation simulates one model over many
# short segments, and the extended-precision powers cost more than a short segment itself.
_LIFTED = ArrayMemo(8)
# Extended-precision powers of the most recent state matrices (of a system, or of a lifted
# one in _block_starts): one longdouble product costs ~50 float64 ones, and systems that
# share A (the state and free-response simulations of one model, the B and x0 regressors
# of a B, D least squares) or simulate again (the block-start levels) need the same powers.
_POWERS = ArrayMemo(16)


def block_length(n: int, m: int, p: int) -> int:
    """Samples per block of :func:`dlsim` for n states, m inputs and p outputs.

    Balances the per-block cost of the block-start states (about 1.5 µs plus n² flops)
    against the per-sample cost of the block-Toeplitz product (L m p flops); the optimum
    is flat.
    """
    per_block = 1.5e-6 + 0.5e-9 * n * n
    per_sample = max(0.3e-9 * m * p, 1e-12)
    return int(np.clip(np.sqrt(per_block / per_sample), 8, 256))


def _lifted(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, L: int
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
    """Observability O (L p, n), Toeplitz T (L p, L m), reachability R (n, L m), Ad^L,
    and whether the powers cancel (then exact: the precise path, see :func:`_cancels`).

    Computed in extended precision (``np.longdouble``, cheap: L n³ flops once) and
    rounded once: a power ``Ad^L`` accumulated in float64 carries a systematic error that
    shifts the eigenvalues of the block recursion by up to (eigenvector condition) × L ×
    eps, and that shift grows linearly over the N / L blocks of a record. Rounded once,
    the error is that of storing ``Ad`` itself. The last result is returned unrounded, for
    the next level of :func:`_block_starts`.
    """
    a, b, c, d = (np.asarray(v, dtype=np.longdouble) for v in (a, b, c, d))
    n, m = b.shape
    p = c.shape[0]
    powers = _powers(a, L)
    precise = _cancels(a, powers)
    # C = I (a simulation of the states) multiplies nothing: skip its L products
    identity = p == n and np.array_equal(c, np.eye(n))
    if precise:  # C Ad^k and Ad^k Bd (k < L) exact: the chain's would carry its loss
        cpa = exact_krylov(a.T, c.T, L - 1).transpose(0, 2, 1)
        apb = exact_krylov(a, b, L - 1)
    else:
        cpa = powers[:L] if identity else c @ powers[:L]
        apb = powers[:L] @ b
    obs = cpa.reshape(L * p, n).astype(float)
    markov = np.concatenate([d[None], apb[:L - 1] if identity else c @ apb[:L - 1]]
                            ).astype(float)                       # D, C Bd, ...
    lag = np.subtract.outer(np.arange(L), np.arange(L))
    blocks = markov[np.maximum(lag, 0)] * (lag >= 0)[:, :, None, None]  # (L, L, p, m)
    toep = blocks.transpose(0, 2, 1, 3).reshape(L * p, L * m)
    reach = apb[::-1].transpose(1, 0, 2).reshape(n, L * m).astype(float)  # [.., Ad Bd, Bd]
    a_l = exact_power(a, L) if precise else powers[L]
    return obs, toep, reach, a_l, precise


def _cancels(a: np.ndarray, powers: np.ndarray) -> bool:
    """Whether the products ``a a^j`` of the power chain cancel more than a normal matrix's.

    The cancellation factor of one product is ``max |a| |a^j| / max |a^(j+1)|`` (1 for a
    nonnegative matrix, a diagonal, a Jordan block; at most about sqrt(n) for a normal
    matrix in any orthonormal basis, whose n terms of a sum add with random signs; about
    ``||a||`` for transient growth: 6e2 and 5e3 at eigenvector condition 1e5 and 1e6 in
    benchmarks/simulate.py). Above sqrt(n) the
    extended-precision chain and the float64 block products lose digits that the
    sample-by-sample recursion keeps.
    """
    a_abs = np.abs(a.astype(float))
    n = a.shape[0]
    mags = np.abs(powers.astype(float))
    # every product of the chain at once (one batched product, not a loop over powers)
    bound = np.max(a_abs @ mags[:-1], axis=(1, 2))
    size = np.max(mags[1:], axis=(1, 2))
    return bool(np.any(bound > np.sqrt(n) * size))


def _powers(a: np.ndarray, count: int) -> np.ndarray:
    """``a^0 .. a^count`` in extended precision, shape (count + 1, n, n), read-only
    (remembered for the last few matrices: see ``_POWERS``)."""
    a = np.asarray(a, dtype=np.longdouble)

    def compute() -> np.ndarray:
        powers = np.empty((count + 1, *a.shape), dtype=np.longdouble)
        powers[0] = np.eye(a.shape[0])
        for k in range(1, count + 1):
            powers[k] = a @ powers[k - 1]
        return powers

    return _POWERS((count, array_key(a)), compute)


def _lifted_cached(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, L: int
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
    """:func:`_lifted`, remembered for the last few systems (see ``_LIFTED``)."""
    return _LIFTED((L, array_key(a, b, c, d)), lambda: _lifted(a, b, c, d, L))


def dlsim(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, u: np.ndarray,
          x0: np.ndarray | None = None, *, return_state: bool = False
          ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Simulate ``x[k+1] = a x[k] + b u[k]``, ``y[k] = c x[k] + d u[k]`` exactly.

    Parameters
    ----------
    a, b, c, d : ndarray
        Discrete state-space matrices, shapes (n, n), (n, m), (p, n), (p, m).
    u : ndarray, shape (N, m)
        Input samples [input units].
    x0 : ndarray, shape (n,), optional
        State at sample 0; zeros when omitted.
    return_state : bool
        Also return the state after the last sample.

    Returns
    -------
    y : ndarray, shape (N, p)
        Output samples [output units].
    x_final : ndarray, shape (n,)
        ``x[N]``; only if `return_state`. Passing it as `x0` of the next call continues
        the simulation seamlessly.
    """
    # a, b may be np.longdouble (second level of _block_starts): kept for _lifted
    a, b = (np.asarray(v) if np.asarray(v).dtype == np.longdouble
            else np.asarray(v, dtype=float) for v in (a, b))
    c, d = (np.asarray(v, dtype=float) for v in (c, d))
    u = np.asarray(u, dtype=float)
    n, m = b.shape
    p = c.shape[0]
    n_samp = u.shape[0]
    x = np.zeros(n) if x0 is None else np.array(x0, dtype=float).reshape(n)
    y = np.empty((n_samp, p))
    if n == 0:
        np.matmul(u, d.T, out=y)
        return (y, x) if return_state else y
    L = block_length(n, m, p)
    nfull = n_samp // L
    if nfull:
        obs, toep, reach, a_l, precise = _lifted_cached(a, b, c, d, L)
        ub = u[:nfull * L].reshape(nfull, L * m)
        xs, x = _block_starts(a_l, ub @ reach.T, x, precise)
        # One product gives a block's outputs from [x_b, U_b]: Y_b = [O T] [x_b; U_b].
        w = np.hstack([obs, toep]).T
        per_chunk = max(1, _CHUNK_SAMPLES // L)
        z = np.empty((min(per_chunk, nfull), n + L * m))
        for b0 in range(0, nfull, per_chunk):
            b1 = min(b0 + per_chunk, nfull)
            z[:b1 - b0, :n], z[:b1 - b0, n:] = xs[b0:b1], ub[b0:b1]
            np.matmul(z[:b1 - b0], w, out=y[b0 * L:b1 * L].reshape(b1 - b0, L * p))
    a, b = a.astype(float), b.astype(float)
    for k in range(nfull * L, n_samp):  # tail shorter than one block
        y[k] = c @ x + d @ u[k]
        x = a @ x + b @ u[k]
    return (y, x) if return_state else y


def _block_starts(a_l: np.ndarray, f: np.ndarray, x: np.ndarray, precise: bool
                  ) -> tuple[np.ndarray, np.ndarray]:
    """States ``x_b`` of ``x_{b+1} = a_l x_b + f_b`` from ``x_0 = x``, and the next one.

    ``a_l`` is in extended precision. Long runs are cut into segments of _SEGMENT steps
    that all start from zero and advance together (one small matrix product per step
    for all segments, where a loop over blocks would pay the Python call overhead per
    block); the true segment-start states follow the same recursion one level up, and
    each segment adds ``a_l^j`` times its start state. `precise` (powers that cancel,
    see :func:`_cancels`): no segments, whose float64 products by ``a_l^j`` amplify
    their rounding; one extended-precision loop over all blocks (about 3 µs + n² long
    double operations per block, where the segments' exact powers of ``a_l`` would cost
    16 n³ integer operations per level).
    """
    nb, n = f.shape
    if precise or nb <= max(_MIN_LIFTED, 2 * _SEGMENT):
        # The top of the hierarchy is the only recursion that carries rounding from block
        # to block: run it in extended precision (a few dozen steps; all blocks on the
        # precise path).
        xs = np.empty_like(f)
        xl = np.asarray(x, dtype=np.longdouble)
        for k in range(nb):
            xs[k] = xl
            xl = a_l @ xl + f[k]
        return xs, xl.astype(float)
    K = _SEGMENT
    n_seg = nb // K
    powers = _powers(a_l, K)
    a_t = np.ascontiguousarray(a_l.astype(float).T)
    fs = f[:n_seg * K].reshape(n_seg, K, n)
    xs = np.empty((nb, n))
    seg = xs[:n_seg * K].reshape(n_seg, K, n)
    z = np.zeros((n_seg, n))
    for j in range(K):  # all segments at once, from zero
        seg[:, j] = z
        z = z @ a_t + fs[:, j]
    starts, x_end = _block_starts(powers[K], z, x, precise)
    # segment s, step j: + a_l^j starts[s]; as one product with [a_l^0 ... a_l^(K-1)]^T
    seg += (starts @ powers[:K].astype(float).transpose(2, 0, 1).reshape(n, K * n)
            ).reshape(n_seg, K, n)
    tail, x_end = _block_starts(a_l, f[n_seg * K:], x_end, precise)
    xs[n_seg * K:] = tail
    return xs, x_end


def _time_base(sys: Any, dt: float | None) -> tuple[bool, float]:
    """(discrete, dt) of `sys` given the caller's `dt`; raises on a mismatch."""
    sys_dt = getattr(sys, "dt", None)
    # python-control: dt 0 = continuous, True = discrete with unspecified interval
    discrete = sys_dt is not None and sys_dt is not False and sys_dt != 0
    if discrete and sys_dt is True:
        dt = 1.0 if dt is None else dt
    elif discrete and dt is None:
        dt = float(sys_dt)
    elif discrete and not np.isclose(float(dt), float(sys_dt), rtol=1e-9, atol=0.0):
        raise ValueError(f"dt={dt} s does not match the discrete system's dt={sys_dt} s; "
                         "pass dt=None or resample the system")
    elif dt is None:
        raise ValueError("dt is required for a continuous-time system: pass the sample "
                         "interval [s]")
    dt = float(dt)
    if not np.isfinite(dt) or dt <= 0.0:
        raise ValueError(f"dt must be a finite sample interval > 0 s, got {dt}")
    return discrete, dt


def _checked_input(u: Any, m: int) -> np.ndarray:
    """`u` as a finite real (N, m) float array."""
    u_arr = np.asarray(u)
    if np.iscomplexobj(u_arr):
        raise TypeError("u must be real-valued")
    u_arr = np.asarray(u_arr, dtype=float)
    if u_arr.ndim == 1 and m == 1:
        u_arr = u_arr[:, None]
    if u_arr.ndim != 2 or u_arr.shape[1] != m:
        raise ValueError(f"u has shape {u_arr.shape}; expected (n_samples, {m}) = "
                         "(n_samples, n_inputs)")
    if u_arr.shape[0] < 1:
        raise ValueError("u must contain at least one sample")
    finite = np.isfinite(u_arr)
    if not finite.all():
        k, i = np.argwhere(~finite)[0]
        raise ValueError(f"u contains NaN or inf (first at sample {k}, input {i}); "
                         "clean the input")
    return u_arr


def lsim(sys: Any, u: np.ndarray, dt: float | None = None, x0: np.ndarray | None = None,
         *, return_states: bool = False
         ) -> tuple[np.ndarray, np.ndarray] | tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Simulate an LTI state-space system driven by a zero-order-hold sampled input.

    Parameters
    ----------
    sys : NamedSS, control.StateSpace or any object with A, B, C, D (and dt)
        Continuous time (``dt`` None, 0 or absent): discretised exactly with ZOH at `dt`
        by ``scipy.signal.cont2discrete(method="zoh")``. Discrete time: used as is; its
        ``dt`` must match `dt` if both are given.
    u : array_like, shape (n_samples, n_inputs) or (n_samples,) for one input
        Input samples, ``u[k]`` held over ``[k dt, (k+1) dt)`` [input units].
    dt : float, optional
        Sample interval [s]; required for a continuous system.
    x0 : array_like, shape (n_states,), optional
        State at time 0. Default zeros.
    return_states : bool
        Also return the state trajectory (memory: ``8 n_samples n_states`` bytes).

    Returns
    -------
    y : ndarray, shape (n_samples, n_outputs)
        ``y[k] = C x[k] + D u[k]``, the output at time ``k dt`` [output units].
    x_final : ndarray, shape (n_states,)
        State at time ``n_samples dt``; passing it as `x0` of the next call continues the
        simulation seamlessly.
    x : ndarray, shape (n_samples, n_states)
        State trajectory ``x[k]``; only if `return_states`.

    Raises
    ------
    TypeError
        If `sys` has no A, B, C, D (convert with ``control.ss`` first) or `u` is complex.
    ValueError
        Missing, non-positive or inconsistent `dt`; `u` or `x0` of the wrong shape or
        not finite; NaN or inf in the system matrices.

    Notes
    -----
    ``control.forced_response`` on a *continuous* system interpolates the input linearly
    between samples (first-order hold); its ZOH equivalent is
    ``control.forced_response(sys.sample(dt, "zoh"), inputs=u.T)``.
    """
    if not all(hasattr(sys, k) for k in "ABCD"):
        raise TypeError(f"sys must be a state space with A, B, C, D, got {type(sys).__name__}"
                        "; convert it with control.ss first")
    a, b, c, d = (np.atleast_2d(np.asarray(getattr(sys, k), dtype=float)) for k in "ABCD")
    for name, mat in zip("ABCD", (a, b, c, d), strict=True):
        if not np.all(np.isfinite(mat)):
            raise ValueError(f"sys.{name} contains NaN or inf; fix the model before simulating")
    n = a.shape[0]
    discrete, dt = _time_base(sys, dt)
    u2 = _checked_input(u, b.shape[1])
    if x0 is not None:
        x0 = np.asarray(x0, dtype=float)
        if x0.shape not in ((n,), (n, 1)) or not np.all(np.isfinite(x0)):
            raise ValueError(f"x0 must be finite with shape ({n},) = (n_states,), "
                             f"got shape {x0.shape}")
    if not discrete and n:
        a, b, *_ = cont2discrete((a, b, c, d), dt, method="zoh")
    if return_states:  # states are extra outputs: C_aug = [C; I], D_aug = [D; 0]
        c_all = np.vstack([c, np.eye(n)])
        d_all = np.vstack([d, np.zeros((n, d.shape[1]))])
        y, x_final = dlsim(a, b, c_all, d_all, u2, x0, return_state=True)
        p = c.shape[0]
        return y[:, :p].copy(), x_final, y[:, p:].copy()
    return dlsim(a, b, c, d, u2, x0, return_state=True)
