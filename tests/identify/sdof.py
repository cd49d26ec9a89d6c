"""A mode's response to white noise, simulated by scipy (not by gbpipe's own draws)."""

from __future__ import annotations

import numpy as np
from scipy import signal


def sdof_response(f0: float, zeta: float, n: int, rng: np.random.Generator, fs: float
                  ) -> np.ndarray:
    """``n`` samples at ``fs`` [Hz] of the velocity of a mode of ``f0`` [Hz] and damping
    ``zeta`` [1] driven by unit white noise: scipy's exact (zero-order hold)
    discretisation, ``scipy.signal.lfilter``."""
    wn = 2 * np.pi * f0
    sysd = signal.cont2discrete((np.array([[0, 1], [-wn ** 2, -2 * zeta * wn]]),
                                 np.array([[0], [1.0]]), np.array([[0, 1.0]]),
                                 np.zeros((1, 1))), 1 / fs)
    b, a = signal.ss2tf(*sysd[:4])
    return signal.lfilter(b[0], a, rng.standard_normal(n))
