"""Hard test systems for the LTI core, and an exact reference simulator.

Used by tests/lti and by benchmarks/simulate.py. Each constructor returns continuous
``(A, B, C, D)`` arrays; :func:`reference_zoh` simulates them with an independent exact
zero-order hold: ``expm`` of the block matrix ``[[A, B], [0, 0]] dt`` (scipy.linalg), then
the sample-by-sample recursion in extended precision (``np.longdouble``), so the
reference's own rounding is far below the 1e-10 tolerance.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from scipy.stats import ortho_group

DT = 2e-4  # s, the bench's sample interval (fs = 5 kHz)


def _io(n: int, m: int, p: int, rng: np.random.Generator):
    return rng.standard_normal((n, m)), rng.standard_normal((p, n)), rng.standard_normal((p, m))


def eigenvector_condition(a: np.ndarray) -> float:
    """2-norm condition number of the unit-column eigenvector matrix of ``a``."""
    _, v = np.linalg.eig(a)
    return float(np.linalg.cond(v / np.linalg.norm(v, axis=0)))


def ill_conditioned(cond: float, n_pairs: int = 3, seed: int = 1, m: int = 2, p: int = 3):
    """Lightly damped system (4 n_pairs states) with eigenvector condition ~ `cond`.

    Each of `n_pairs` modes (20-60 Hz, 2 % damping) appears twice, the copies detuned by
    a relative ``1/cond`` and coupled one way (as two nearly identical gearboxes driven
    through a shaft): the eigenvector pairs are nearly parallel, and ``A`` stays of the
    size of the physics (no artificial transient growth). A random orthogonal change of
    basis mixes all states.
    """
    rng = np.random.default_rng(seed)
    n = 4 * n_pairs
    a = np.zeros((n, n))
    for i, f in enumerate(np.linspace(20.0, 60.0, n_pairs)):
        w, z = 2 * np.pi * f, 0.02
        for j, wj in enumerate((w, w * (1 + 1.0 / cond))):
            k = 4 * i + 2 * j
            a[k:k + 2, k:k + 2] = [[0.0, 1.0], [-wj * wj, -2 * z * wj]]
        a[4 * i + 1, 4 * i + 2] = w * w  # coupling of the first copy to the second
    q = ortho_group.rvs(n, random_state=rng)
    return (q @ a @ q.T, *_io(n, m, p, rng))


def transient_growth(cond: float, n_pairs: int = 6, seed: int = 1, m: int = 2, p: int = 3):
    """Lightly damped oscillator (2 n_pairs states, modes 20-60 Hz) made non-normal by an
    eigenvector matrix of condition `cond` with spread eigenvalues: ``||A||`` grows like
    `cond` (transient growth). Ill-posed in float64: even the sample-by-sample
    recursion loses digits (see benchmarks/simulate.py)."""
    rng = np.random.default_rng(seed)
    n = 2 * n_pairs
    lam = np.zeros((n, n))
    for i, f in enumerate(np.linspace(20.0, 60.0, n_pairs)):
        w, z = 2 * np.pi * f, 0.02
        lam[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[-z * w, w * np.sqrt(1 - z * z)],
                                                 [-w * np.sqrt(1 - z * z), -z * w]]
    s = np.geomspace(1.0, 1.0 / cond, n)
    v = ortho_group.rvs(n, random_state=rng) @ np.diag(s) @ ortho_group.rvs(
        n, random_state=rng)
    a = v @ lam @ np.linalg.inv(v)
    return (a, *_io(n, m, p, rng))


def jordan(n: int = 6, pole: float = -30.0, seed: int = 2, eps: float = 0.0):
    """Defective ``A``: one Jordan block of size `n` at `pole` [1/s] (``eps`` = 0), or a
    near-defective one whose diagonal is split by `eps` [1/s]."""
    rng = np.random.default_rng(seed)
    a = pole * np.eye(n) + 30.0 * np.eye(n, k=1) + np.diag(eps * np.arange(n))
    return (a, *_io(n, 2, 2, rng))


def integrators(seed: int = 3):
    """A pure triple integrator (Jordan block at 0) beside a lightly damped mode."""
    rng = np.random.default_rng(seed)
    a = np.zeros((5, 5))
    a[0, 1] = a[1, 2] = 1.0
    w = 2 * np.pi * 40.0
    a[3:, 3:] = [[0.0, 1.0], [-w * w, -0.04 * w]]
    return (a, *_io(5, 2, 3, rng))


def reference_zoh(a, b, c, d, u, dt=DT, x0=None) -> np.ndarray:
    """Exact ZOH response, independent of gbpipe (see the module docstring)."""
    n, m = b.shape
    big = np.zeros((n + m, n + m))
    big[:n, :n], big[:n, n:] = a * dt, b * dt
    e = scipy.linalg.expm(big)
    ad, bd = (np.asarray(x, dtype=np.longdouble) for x in (e[:n, :n], e[:n, n:]))
    cl, dl = np.asarray(c, dtype=np.longdouble), np.asarray(d, dtype=np.longdouble)
    x = np.zeros(n, dtype=np.longdouble) if x0 is None else np.asarray(x0, np.longdouble)
    ul = np.asarray(u, dtype=np.longdouble)
    y = np.empty((len(u), c.shape[0]), dtype=np.longdouble)
    for k in range(len(u)):
        y[k] = cl @ x + dl @ ul[k]
        x = ad @ x + bd @ ul[k]
    return y.astype(float)


def relative_error(y: np.ndarray, y_ref: np.ndarray) -> float:
    """Largest ``|y - y_ref|`` relative to the largest ``|y_ref|`` of the same output."""
    return float(np.max(np.abs(y - y_ref).max(axis=0) / np.abs(y_ref).max(axis=0)))


# Discrete systems for the round-off-floor tests: all of 12 states, 2 inputs, 3 outputs,
# lightly damped (slowest |lam| > 0.999), so that one batched recursion serves them all.
N_STATES, N_INPUTS, N_OUTPUTS = 12, 2, 3


def _rotation(radius: float, angle: float) -> np.ndarray:
    """Real 2 x 2 block of the eigenvalue pair ``radius exp(±i angle)``."""
    cos, sin = np.cos(angle), np.sin(angle)
    return radius * np.array([[cos, sin], [-sin, cos]])


def _mixed(core: np.ndarray, cond: float, rng: np.random.Generator):
    """``V core V^-1`` with ``V = U diag(s) W^T`` (``U``, ``W`` random orthogonal, ``s``
    geometric from 1 to ``1/cond``), and random B, C, D."""
    n = core.shape[0]
    v = (ortho_group.rvs(n, random_state=rng) @ np.diag(np.geomspace(1.0, 1.0 / cond, n))
         @ ortho_group.rvs(n, random_state=rng))
    return (v @ core @ np.linalg.inv(v), *_io(n, N_INPUTS, N_OUTPUTS, rng))


def nonnormal_discrete(cond: float, seed: int):
    """Discrete, 6 lightly damped pairs (|lam| 0.999-0.9999, 0.01-0.5 rad/sample), made
    non-normal by an eigenvector matrix of condition ~ `cond` (``||A||`` grows with it)."""
    rng = np.random.default_rng(seed)
    core = np.zeros((N_STATES, N_STATES))
    for i in range(0, N_STATES, 2):
        core[i:i + 2, i:i + 2] = _rotation(rng.uniform(0.999, 0.9999), rng.uniform(0.01, 0.5))
    return _mixed(core, cond, rng)


def jordan_discrete(split: float, seed: int, cond: float = 1e3):
    """Discrete, defective (``split`` 0) or near-defective: the real Jordan form of a
    lightly damped pair repeated three times (6 states, |lam| 0.9995) beside a real
    Jordan block of size 6 at 0.9992, diagonals detuned by ``split``; couplings 1e-3
    (a discretised rate times the sample interval), mixed by condition `cond`."""
    rng = np.random.default_rng(seed)
    core = np.zeros((N_STATES, N_STATES))
    for i in range(3):
        core[2 * i:2 * i + 2, 2 * i:2 * i + 2] = _rotation(0.9995 * (1 + split * i), 0.2)
        if i:
            core[2 * i - 2:2 * i, 2 * i:2 * i + 2] = 1e-3 * np.eye(2)
    core[6:, 6:] = (np.diag(0.9992 * (1 + split * np.arange(6))) + 1e-3 * np.eye(6, k=1))
    return _mixed(core, cond, rng)


def integrators_discrete(seed: int, cond: float = 1e4):
    """Discrete triple integrator (Jordan block of size 3 at lam = 1, couplings 1e-3)
    beside lightly damped pairs (|lam| 0.9995-0.9999) and one real pole at 0.999, mixed
    by condition `cond`."""
    rng = np.random.default_rng(seed)
    core = np.zeros((N_STATES, N_STATES))
    core[:3, :3] = np.eye(3) + 1e-3 * np.eye(3, k=1)
    for i in range(3, N_STATES - 1, 2):
        core[i:i + 2, i:i + 2] = _rotation(rng.uniform(0.9995, 0.9999), rng.uniform(0.01, 0.5))
    core[-1, -1] = 0.999
    return _mixed(core, cond, rng)


def recursions(systems: list[tuple[np.ndarray, ...]], u: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Outputs of the plain recursion ``x[k+1] = A x[k] + B u[k]``, ``y[k] = C x[k] +
    D u[k]`` from ``x[0] = 0`` for each system, all driven by `u` (N, m): in extended
    precision (``np.longdouble``, the reference) and in float64 (the round-off floor).

    Returns (y_ld, y_64), each (n_systems, N, p); y_ld stays in extended precision. One
    loop over samples for all systems (stacked matrices), independent of gbpipe.
    """
    out = []
    for dtype in (np.longdouble, np.float64):
        a, b, c, d = (np.stack([s[i] for s in systems]).astype(dtype) for i in range(4))
        uk = u.astype(dtype)
        x = np.zeros(a.shape[:2], dtype=dtype)
        y = np.empty((len(systems), len(u), c.shape[1]), dtype=dtype)
        for k in range(len(u)):
            y[:, k] = np.einsum("sij,sj->si", c, x) + d @ uk[k]
            x = np.einsum("sij,sj->si", a, x) + b @ uk[k]
        out.append(y)
    return out[0], out[1]
