"""Hand-built records for the removal-method tests, independent of gbpipe.

Known harmonics (amplitude and phase that vary slowly and smoothly with time) on an
exact angle law, a known broadband part (white or resonance-filtered noise from a fixed
seed), and pulse times from the exact inverse of the angle. The linear 400 -> 1120 rpm
sweep of :mod:`harmonic_sweeps` gives the varying speed; :func:`constant_speed` a
constant one, where orders are fixed frequencies.
"""

from __future__ import annotations

import numpy as np
from harmonic_sweeps import make_sweep

#: (order, amplitude, phase [rad], relative modulation depth): a shaft family 1, 2, 3
#: and a non-integer mesh family 5.3569 x (1, 2).
LINES = [(1.0, 0.3, 0.2, 0.3), (2.0, 0.2, 1.0, 0.5), (3.0, 1.0, -0.5, 0.4),
         (5.3569, 0.7, 0.4, 0.3), (10.7138, 0.3, 2.0, 0.2)]
FAMILIES = {"shaft": [1.0, 2.0, 3.0], "mesh": [5.3569, 10.7138]}


def modulated_harmonics(t: np.ndarray, theta: np.ndarray, lines=LINES,
                        period: float = 12.0) -> np.ndarray:
    """Sum of ``a(t) cos(o theta + phi(t))``: amplitude ``a0 (1 + depth sin(2 pi t / T))``
    and phase ``phi0 + depth cos(2 pi t / T)`` [rad], both slow (period T [s])."""
    w = 2 * np.pi * t / period
    return sum(a * (1 + d * np.sin(w)) * np.cos(o * theta + ph + d * np.cos(w))
               for o, a, ph, d in lines)


def sweep(noise: float = 0.0, seed: int = 3, white: bool = True,
          duration: float = 20.0) -> dict:
    """The 4 kHz linear 400 -> 1120 rpm sweep with modulated harmonics and a broadband
    part (20 s: the sweep of :mod:`harmonic_sweeps` twice as fast).

    ``white``: the broadband part is white noise of rms ``noise``; otherwise the 62 Hz
    resonance response of :func:`harmonic_sweeps.make_sweep`.
    """
    sw = make_sweep(noise=noise if not white else 0.0, seed=seed, duration=duration)
    sw["h"] = modulated_harmonics(sw["t"], sw["theta"])
    if white:
        sw["res"] = noise * np.random.default_rng(seed).standard_normal(sw["t"].size)
    sw["x"] = sw["h"] + sw["res"]
    return sw


def constant_speed(rpm: float = 600.0, fs: float = 4000.0, duration: float = 30.0) -> dict:
    """Time, exact angle (first pulse at 0 rad) and pulse times at constant speed."""
    t = np.arange(int(round(duration * fs))) / fs
    f_rot = rpm / 60.0
    t_first = 0.5 / fs + 0.01  # first pulse between samples, inside the record
    theta = 2 * np.pi * f_rot * (t - t_first)
    pulses = t_first + np.arange(int((t[-1] - t_first) * f_rot) + 1) / f_rot
    return dict(t=t, theta=theta, pulses=pulses, fs=fs, f_rot=f_rot)


def inner(t: np.ndarray, pulses: np.ndarray, margin: float) -> np.ndarray:
    """Samples more than ``margin`` s inside the pulse span (away from the edges)."""
    return (t > pulses[0] + margin) & (t < pulses[-1] - margin)


def db(num: float, den: float) -> float:
    """10 log10 of a power ratio."""
    return float(10 * np.log10(num / den))
