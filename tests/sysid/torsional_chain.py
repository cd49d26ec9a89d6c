"""A grounded torsional chain of random inertias with closed-form M, K, C, for the modal tests.

Inertia 0 is tied to the ground by a spring (no rigid-body mode); springs join neighbours.
Damping is modal: ``C = M Phi diag(2 zeta_r omega_r) Phi' M`` with mass-normalised modes
``Phi`` of ``K Phi = M Phi Omega^2``, so every mode has its drawn damping ratio exactly. The
true modes come from ``scipy.linalg.eig`` of the continuous state matrix, independently of
the code under test.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sl
import scipy.signal as ss


@dataclass(frozen=True)
class Chain:
    """Continuous model (A, B, C) of the chain, its true modes and a sample time."""

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    frequency_hz: np.ndarray  # true natural frequencies, ascending [Hz]
    damping: np.ndarray  # true damping ratios [1]
    dt: float  # sample time [s]: 8 samples per period of the highest mode
    peak: np.ndarray  # each mode's largest resonance peak |R_r| / |Re s_r| over the
    # largest mode's [1]: a mode far below 1 is buried under measurement noise


def chain(seed: int, n: int = 6, inputs: tuple[int, ...] = (0,),
          outputs: tuple[int, ...] = (0, 2, 5), min_separation: float = 0.1) -> Chain:
    """Draw a chain whose modes are at least ``min_separation`` (relative) apart.

    Inputs are torques [N m] on the listed inertias, outputs their speeds [rad/s].
    """
    rng = np.random.default_rng(seed)
    while True:
        inertia = rng.uniform(0.5, 2.0, n)  # kg m^2
        k = rng.uniform(2e4, 8e4, n)  # N m/rad: k[0] to ground, k[i] joins i-1 and i
        stiff = np.diag(k + np.append(k[1:], 0.0))
        stiff -= np.diag(k[1:], 1) + np.diag(k[1:], -1)
        mass = np.diag(inertia)
        w2, phi = sl.eigh(stiff, mass)
        wn = np.sqrt(w2)
        if np.min(np.diff(wn) / wn[1:]) >= min_separation:
            break
    zeta = rng.uniform(0.005, 0.03, n)
    damp = mass @ phi @ np.diag(2 * zeta * wn) @ phi.T @ mass
    a = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(mass, stiff), -np.linalg.solve(mass, damp)]])
    b = np.zeros((2 * n, len(inputs)))
    for j, i in enumerate(inputs):
        b[n + i, j] = 1.0 / inertia[i]
    c = np.zeros((len(outputs), 2 * n))
    for j, o in enumerate(outputs):
        c[j, n + o] = 1.0
    ev, left, right = sl.eig(a, left=True, right=True)
    idx = np.flatnonzero(ev.imag > 0)
    idx = idx[np.argsort(np.abs(ev[idx]))]
    ev = ev[idx]
    # Residue of pole r: C v_r w_r^H B / (w_r^H v_r); its peak gain |R_r| / |Re s_r|.
    peak = np.array([np.abs(np.outer(c @ right[:, j], left[:, j].conj() @ b)).max()
                     / abs(left[:, j].conj() @ right[:, j]) for j in idx]) / np.abs(ev.real)
    f = np.abs(ev) / (2 * np.pi)
    return Chain(a=a, b=b, c=c, frequency_hz=f, damping=-ev.real / np.abs(ev),
                 dt=1.0 / (8.0 * f.max()), peak=peak / peak.max())


def discrete(ch: Chain) -> tuple[np.ndarray, ...]:
    """Zero-order-hold ``(Ad, Bd, Cd, Dd)``: poles ``exp(s dt)`` exactly."""
    ad, bd, cd, dd, _ = ss.cont2discrete((ch.a, ch.b, ch.c, np.zeros((ch.c.shape[0],
                                                                        ch.b.shape[1]))), ch.dt)
    return ad, bd, cd, dd


def record(ch: Chain, n_samples: int, noise: float, seed: int
           ) -> tuple[np.ndarray, np.ndarray]:
    """White-noise torque in, speeds out with white measurement noise of ``noise`` times
    each output's RMS."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((n_samples, ch.b.shape[1]))
    ad, bd, cd, dd = discrete(ch)
    _, y, _ = ss.dlsim((ad, bd, cd, dd, ch.dt), u)
    y = y + noise * y.std(axis=0) * rng.standard_normal(y.shape)
    return u, y


def assert_true_modes(st, ch: Chain) -> np.ndarray:
    """Check a ``Stabilization`` against the chain's true modes; return the matched modes.

    Every cluster is a distinct true mode (no noise pole reported) within 1 % in frequency;
    every mode well above the noise (peak > 1/20 of the largest) is found, its damping
    within 20 % (a mode near the noise floor may be found, its damping less sure); the
    chosen order has a pole within 1 % of every found mode, the order before it has not.
    """
    f_est = np.array([m.frequency_hz for m in st.clusters])
    z_est = np.array([m.damping for m in st.clusters])
    near = np.argmin(np.abs(f_est[:, None] / ch.frequency_hz[None, :] - 1), axis=1)
    assert np.unique(near).size == near.size
    np.testing.assert_array_less(np.abs(f_est / ch.frequency_hz[near] - 1), 0.01)
    strong = ch.peak[near] > 0.05
    np.testing.assert_array_less(np.abs(z_est / ch.damping[near] - 1)[strong], 0.20)
    assert set(np.flatnonzero(ch.peak > 0.05)) <= set(near)

    def holds(k: int) -> bool:
        f = st.poles[k][0]
        return f.size > 0 and bool(np.all(
            np.min(np.abs(f[None, :] / ch.frequency_hz[near, None] - 1), axis=1) <= 0.01))

    k = list(st.orders).index(st.order)
    assert holds(k)
    assert k == 0 or not holds(k - 1)
    return near
