"""``B, D`` of MOESP/N4SID when the estimated ``A`` is unstable (closed-loop, low-passed data).

An over-specified order on a low-passed closed-loop record gives ``A`` spurious poles on or
outside the unit circle. ``B, D`` then used to come from ``Gamma_perp' Psi_u =
Gamma_perp' H_f(B, D)`` with ``H_f`` built from powers of ``A``: ``C A^k`` grows like
``|z|^(f-1)`` and only the first ``f`` Markov parameters enter, so the low-frequency gain was
tens of dB off, and on a bench record (spurious pole at ``z = -4.4``, ``f = 50``) ``B``
collapsed to 1e-30 (a zero FRF). They now come from the whole-record least squares in
predictor form (``A - K C`` stable). References: the true plant's FRF from
``C (zI - A)^-1 B + D`` (numpy), closed-loop data from ``scipy.signal.dlsim``.
"""

from __future__ import annotations

import numpy as np
import scipy.signal as sig
from sysid_plants import innovation_gain, torsional_plant, two_mode_plant

from gbpipe.sysid import moesp
from gbpipe.sysid.input_matrices import bd_least_squares

DT = 1e-3  # s


def closed_loop_lowpassed(n_samples: int, kp: float, snr_db: float, stop_db: float, seed: int = 0):
    """Proportional loop ``u = r - kp (y + v)`` around :func:`torsional_plant` (torque in
    N m, speed in rad/s), white reference ``r`` and white output noise ``v`` at ``snr_db``
    against the noise-free output; ``u`` and ``y`` then low-passed at 0.8 x Nyquist as the
    identify stage's decimation leaves them (Kaiser FIR, ``stop_db`` stop band).

    Returns
    -------
    u, y : ndarray, shape (n_samples,)
    plant : tuple
        ``(A, B, C, D)`` between the unfiltered signals (the common FIR cancels in the FRF).
    """
    A, B, C, D = torsional_plant(DT)
    rng = np.random.default_rng(seed)
    r = rng.standard_normal(n_samples)
    v = rng.standard_normal(n_samples)
    # Closed loop with inputs [r, v] and outputs [u, y]; the plant has no feedthrough.
    loop = (A - kp * B @ C, np.hstack([B, -kp * B]), np.vstack([-kp * C, C]),
            np.array([[1.0, -kp], [0.0, 1.0]]), DT)
    y_clean = sig.dlsim(loop, np.column_stack([r, 0.0 * v]))[1][:, 1]
    out = sig.dlsim(loop, np.column_stack([r, v * 10 ** (-snr_db / 20) * y_clean.std()]))[1]
    h = sig.firwin(161, 0.8, window=("kaiser", sig.kaiser_beta(stop_db)))
    return sig.lfilter(h, 1.0, out[:, 0]), sig.lfilter(h, 1.0, out[:, 1]), (A, B, C, D)


def test_moesp_unstable_estimate_keeps_the_frf_in_closed_loop():
    # Order 24 for a 4th-order plant: MOESP places a spurious pair at |z| >= 1 (333 Hz).
    u, y, plant = closed_loop_lowpassed(20_000, kp=5.0, snr_db=80.0, stop_db=100.0)
    model = moesp(u, y, order=24, horizon=50, past=100, dt=DT)
    assert np.any(np.abs(model.poles) >= 1.0), "the case no longer exercises an unstable A"
    f = np.geomspace(1.0, 300.0, 40)  # Hz: both modes (3.7, 12.6 Hz) and the pass band
    A, B, C, D = plant
    g_true = np.array([(C @ np.linalg.solve(np.exp(2j * np.pi * fk * DT) * np.eye(4) - A, B)
                        + D)[0, 0] for fk in f])
    err_db = 20 * np.log10(np.abs(model.frf(f)[:, 0, 0]) / np.abs(g_true))
    print(f"max |FRF error| {np.abs(err_db).max():.2f} dB")
    # Measured 0.26 dB; the Gamma_perp equations gave 19 dB (low frequencies).
    assert np.abs(err_db).max() < 1.0


def test_predictor_form_recovers_b_and_d_exactly():
    # Noise-free data: the predictor form x+ = (A - K C) x + (B - K D) u + K y is an exact
    # reparametrisation, so any stabilising K gives the true B and D (here a feedthrough).
    A, B, C, _ = two_mode_plant()
    D = np.array([[0.7]])
    K = innovation_gain(A, C)
    u = np.random.default_rng(1).standard_normal(4000)
    y = sig.dlsim((A, B, C, D, 1.0), u, x0=np.ones(A.shape[0]))[1][:, 0]
    z = np.vstack([u, y])
    b_hat, d_hat = bd_least_squares(A, C, z, 1, True, gain=K)
    np.testing.assert_allclose(b_hat, B, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(d_hat, D, rtol=1e-7)
    # Same answer as the output-error form (K = 0) for this stable A.
    b_oe, d_oe = bd_least_squares(A, C, z, 1, True)
    np.testing.assert_allclose(b_hat, b_oe, rtol=1e-7, atol=1e-9)
