"""Known systems and data sets for testing and benchmarking the identification methods.

One implementation shared by ``tests/sysid/`` and ``benchmarks/sysid.py`` (which puts this
folder on ``sys.path``): a 4th-order plant with two lightly damped resonances, the gain that
colours its noise, closed-loop data from a PI controller around it, and a reference
simulator that shares no code with gbpipe (``scipy.signal.lfilter`` per input/output pair).
"""

from __future__ import annotations

import numpy as np
import scipy.signal as sig

__all__ = ["two_mode_plant", "innovation_gain", "closed_loop_data", "simulate"]


def simulate(A, B, C, D, u):
    """Zero-state response of ``x+ = A x + B u``, ``y = C x + D u`` to ``u`` (N, m).

    Independent of :mod:`gbpipe.lti`: each input/output pair is converted to a transfer
    function (``scipy.signal.ss2tf``) and filtered with ``scipy.signal.lfilter``. Fine for
    the low-order, well-conditioned plants of these tests.

    Returns
    -------
    ndarray, shape (N, l)
    """
    u = np.asarray(u, dtype=float).reshape(len(u), -1)
    y = np.zeros((u.shape[0], C.shape[0]))
    for j in range(u.shape[1]):
        num, den = sig.ss2tf(A, B, C, D, input=j)
        for i in range(C.shape[0]):
            y[:, i] += sig.lfilter(num[i], den, u[:, j])
    return y


def two_mode_plant(d: float = 0.0):
    """4th-order SISO plant (dt = 1): resonances at 0.1 and 0.3 × fs, ζ = 0.02 and 0.01.

    Zeros at ±0.5 (relative degree 2), unit static gain, feedthrough ``d``.

    Returns
    -------
    A, B, C, D : ndarray
    """
    poles = []
    for f, zeta in ((0.1, 0.02), (0.3, 0.01)):
        w = 2 * np.pi * f
        s = -zeta * w + 1j * w * np.sqrt(1 - zeta**2)
        poles += [np.exp(s), np.exp(np.conj(s))]
    a = np.real(np.poly(poles))
    b = np.array([1.0, 0.0, -0.25])
    b *= a.sum() / b.sum()
    A, B, C, _ = sig.tf2ss(b, a)
    return A, B, C, np.array([[d]])


def innovation_gain(A: np.ndarray, C: np.ndarray, radius: float = 0.7) -> np.ndarray:
    """Kalman-like gain placing the predictor poles ``A − K C`` at ``radius`` (same angles
    as the plant poles): noise ``H e`` with ``H = C (qI − A)⁻¹ K + I`` is then coloured."""
    poles = radius * np.exp(1j * np.angle(np.linalg.eigvals(A)))
    return sig.place_poles(A.T, C.T, poles).gain_matrix.T


def closed_loop_data(n_samples: int, snr_db: float, seed: int = 3,
                     kp: float = 0.3, ki: float = 0.05):
    """PI loop around :func:`two_mode_plant`, white reference, coloured innovation noise.

    The noise is scaled (a fixed point, since feedback feeds it back into the input) so that
    the output has the wanted signal-to-noise ratio against the noise-free response to the
    same input.

    Returns
    -------
    u, y, y0 : ndarray, shape (n_samples,)
        Input, noisy output and noise-free output ``G u``.
    plant : tuple
        ``(A, B, C, D)``.
    snr_db : float
        The SNR achieved [dB].
    """
    A, B, C, D = two_mode_plant()
    K = innovation_gain(A, C)
    rng = np.random.default_rng(seed)
    r = rng.standard_normal(n_samples)
    e0 = rng.standard_normal(n_samples)

    def run(e):
        x = np.zeros(A.shape[0])
        xi = 0.0
        u = np.empty(n_samples)
        y = np.empty(n_samples)
        c, b, k = C[0], B[:, 0], K[:, 0]
        for t in range(n_samples):  # the controller acts on the current sample: a loop
            y[t] = c @ x + e[t]
            err = r[t] - y[t]
            u[t] = kp * err + xi
            xi += ki * err
            x = A @ x + b * u[t] + k * e[t]
        return u, y

    scale = 1.0
    for _ in range(4):
        u, y = run(scale * e0)
        y0 = simulate(A, B, C, D, u[:, None])[:, 0]
        scale *= np.sqrt(10 ** (-snr_db / 10) / (np.var(y - y0) / np.var(y0)))
    u, y = run(scale * e0)
    y0 = simulate(A, B, C, D, u[:, None])[:, 0]
    return u, y, y0, (A, B, C, D), float(10 * np.log10(np.var(y0) / np.var(y - y0)))
