"""Synthetic sweeps for the harmonic-removal tests, independent of any bench model.

A linear 400 -> 1120 rpm sweep, angle from the exact integral of the rpm profile, pulse
times from the analytic inverse of that angle; HSS orders 1, 2, 3 (3 strongest), a
non-integer "mesh" family 5.3569 x (1, 2, 3), and white noise through a 62 Hz, 2 % damped
resonance. Removal is judged by least-squares projection on the exact sinusoids of the
true angle (:func:`line_power`), not by gbpipe's own order tracking.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from scipy import signal

MESH = 5.3569
CARRIER = Fraction(29 * 21, 96 * 135)  # stage-2 carrier in HSS orders; MESH ~ 114 x this
FS = 4000.0
T = 40.0
HSS_LINES = [(1, 0.3, 0.2), (2, 0.2, 1.0), (3, 1.0, -0.5)]
MESH_LINES = [(1, 0.7, 0.4), (2, 0.3, 2.0), (3, 0.15, -1.0)]


def make_sweep(fs: float = FS, duration: float = T, rpm0: float = 400.0, rpm1: float = 1120.0,
               noise: float = 0.3, seed: int = 0, mesh: float = MESH, res_hz: float = 62.0,
               pulses_per_rev: int = 1) -> dict:
    """Synthetic sweep: components, their sum and the tachometer pulse times."""
    rng = np.random.default_rng(seed)
    n = int(round(duration * fs))
    t = np.arange(n) / fs
    a = np.pi * (rpm1 - rpm0) / 60.0 / duration  # theta(t) = a t^2 + b t, exact
    b = 2 * np.pi * rpm0 / 60.0
    theta = a * t**2 + b * t
    hss = sum(amp * np.cos(k * theta + ph) for k, amp, ph in HSS_LINES)
    msh = sum(amp * np.cos(k * mesh * theta + ph) for k, amp, ph in MESH_LINES)
    w0, z = 2 * np.pi * res_hz, 0.02
    bz, az = signal.bilinear([w0**2], [1.0, 2 * z * w0, w0**2], fs)
    res = signal.lfilter(bz, az, rng.standard_normal(n))
    res *= noise / res.std() if noise > 0 else 0.0
    k = np.arange(1, int(theta[-1] / (2 * np.pi / pulses_per_rev)) + 1)
    th_k = 2 * np.pi * k / pulses_per_rev
    pulses = (-b + np.sqrt(b * b + 4 * a * th_k)) / (2 * a)
    rpm = rpm0 + (rpm1 - rpm0) * t / duration
    return dict(t=t, fs=fs, theta=theta, hss=hss, mesh=msh, res=res, x=hss + msh + res,
                pulses=pulses, rpm=rpm, mesh_order=mesh)


def line_power(y: np.ndarray, theta: np.ndarray, orders, mask) -> float:
    """Power of y at the given orders of the true angle (least-squares projection)."""
    cols = []
    for o in orders:
        cols += [np.cos(o * theta[mask]), np.sin(o * theta[mask])]
    coef, *_ = np.linalg.lstsq(np.array(cols).T, y[mask], rcond=None)
    return float(np.sum(coef**2) / 2)


def db(ratio: float) -> float:
    return float(10 * np.log10(ratio))


HSS_ORDERS = [1, 2, 3]
MESH_ORDERS = [MESH * k for k in (1, 2, 3)]
