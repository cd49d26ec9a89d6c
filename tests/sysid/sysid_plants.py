"""Known systems and data sets for testing and benchmarking the identification methods.

One implementation shared by ``tests/sysid/`` and ``benchmarks/sysid.py`` (which puts this
folder on ``sys.path``): a 4th-order plant with two lightly damped resonances, the gain that
colours its noise, closed-loop data from a PI controller around it, and a reference
simulator that shares no code with gbpipe (``scipy.signal.lfilter`` per input/output pair).
"""

from __future__ import annotations

import numpy as np
import scipy.signal as sig
from scipy.linalg import expm as sla_expm

__all__ = ["two_mode_plant", "modal_plant", "innovation_gain", "closed_loop_data", "simulate",
           "stage_data", "torsional_plant"]


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


def modal_plant(n_modes: int, n_inputs: int, n_outputs: int, dt: float, seed: int = 0,
                band: tuple[float, float] = (5.0, 300.0), zeta: float = 0.03):
    """Stable discrete modal plant: ``n_modes`` resonances spread log-uniformly over ``band``.

    Each mode ``k`` (frequency ``f_k`` [Hz], damping ``zeta``) is a 2-state block in real
    modal form, discretised exactly (``expm``); random input/output participation. Order
    ``2 n_modes``, no feedthrough. Stands in for a drive-train pairing at the identify
    stage's size (order 24 = 12 modes at 1 kHz).

    Returns
    -------
    A, B, C, D : ndarray
    """
    rng = np.random.default_rng(seed)
    freqs = np.geomspace(band[0], band[1], n_modes)
    n = 2 * n_modes
    ac = np.zeros((n, n))
    for k, f in enumerate(freqs):
        w = 2 * np.pi * f
        sigma, wd = zeta * w, w * np.sqrt(1 - zeta**2)
        ac[2 * k: 2 * k + 2, 2 * k: 2 * k + 2] = [[-sigma, wd], [-wd, -sigma]]
    A = np.real(sla_expm(ac * dt))
    B = rng.standard_normal((n, n_inputs)) * np.repeat(2 * np.pi * freqs, 2)[:, None] * dt
    C = rng.standard_normal((n_outputs, n))
    return A, B, C, np.zeros((n_outputs, n_inputs))


def stage_data(n_samples: int, n_inputs: int, n_outputs: int, seed: int = 0,
               snr_db: float = 20.0, dt: float = 1e-3, stop_db: float = 80.0):
    """Identify-stage-sized record: order-24 :func:`modal_plant`, white input, white output
    noise at ``snr_db`` per output, then both low-passed at 0.8 x Nyquist by a linear-phase
    FIR (Kaiser, ``stop_db`` stop-band attenuation), as the decimation of the identify stage
    leaves them: the band above the cut-off is empty, which makes the data Hankel matrix ill
    conditioned (cond ~ 10^(stop_db / 20)).

    Returns
    -------
    u, y : ndarray, shapes (N, m), (N, l)
    plant : tuple
        ``(A, B, C, D)`` of the plant between the unfiltered signals (the common FIR
        cancels in the FRF).
    """
    plant = modal_plant(12, n_inputs, n_outputs, dt, seed)
    rng = np.random.default_rng(seed + 1000)
    u = rng.standard_normal((n_samples, n_inputs))
    # State-space simulation (a 24th-order transfer function would be too ill-conditioned).
    y0 = sig.dlsim((*plant, dt), u)[1].reshape(n_samples, n_outputs)
    y = y0 + 10 ** (-snr_db / 20) * y0.std(axis=0) * rng.standard_normal(y0.shape)
    h = sig.firwin(161, 0.8, window=("kaiser", sig.kaiser_beta(stop_db)))
    return sig.lfilter(h, 1.0, u, axis=0), sig.lfilter(h, 1.0, y, axis=0), plant


def torsional_plant(dt: float):
    """2-DOF torsional system, ZOH-discretised: torque on inertia 1 -> speed of inertia 2.

    Inertias 1.0 and 0.5 kg m^2, each tied to the ground by 400 N m/rad (so no rigid-body
    integrator) and to each other by 2000 N m/rad, viscous damping 0.5 N m s/rad to the
    ground and 1.0 between them: two lightly damped modes near 3.7 and 12.6 Hz.

    Returns
    -------
    A, B, C, D : ndarray
        Discrete time, sample time ``dt`` [s]; input N m, output rad/s.
    """
    j = np.diag([1.0, 0.5])
    k = np.array([[400.0 + 2000.0, -2000.0], [-2000.0, 400.0 + 2000.0]])
    c = np.array([[0.5 + 1.0, -1.0], [-1.0, 0.5 + 1.0]])
    ji = np.linalg.inv(j)
    ac = np.block([[np.zeros((2, 2)), np.eye(2)], [-ji @ k, -ji @ c]])
    bc = np.vstack([np.zeros((2, 1)), ji @ [[1.0], [0.0]]])
    cc = np.array([[0.0, 0.0, 0.0, 1.0]])
    A, B, C, D, _ = sig.cont2discrete((ac, bc, cc, np.zeros((1, 1))), dt, method="zoh")
    return A, B, C, D
