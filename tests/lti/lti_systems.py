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
