"""Measured-like noise of the bench: motor torque ripple and encoder speed quantisation.

* **Motor torque ripple** (process noise, enters the bench at ``disturbance_driver`` /
  ``disturbance_driven``): per motor a broadband white part [N·m rms at the sample rate]
  and a converter *pulsating* torque ``sum_h A_h sin(h p theta + phi_h)`` at the
  multiples ``h`` of the electrical frequency of a machine with ``p`` pole pairs, locked
  to the motor shaft angle ``theta``: the driver motor drives the GB2 HSS, the driven motor
  sits on the GB1 HSS (:data:`MOTOR_ANGLE`). The phases ``phi_h`` are hardware (rotor
  position against the HSS angle zero): one draw per configuration seed.
* **Encoder quantisation**: a speed signal is the first difference of a shaft angle
  quantised to ``q = 2 pi / counts_per_rev``, divided by ``dt``. :func:`quantisation_noise`
  gives that estimate's error ``(e[k] - e[k-1]) / dt`` with ``e = floor(theta / q) q -
  theta``. When the fractional part of the counts moved per sample is spread evenly (the
  speed wanders by more than ``q / dt``: 0.0037 rad/s at 2^23 counts and 5 kHz), ``e`` is
  white and uniform (variance ``q**2 / 12``), so the error is a first-order MA noise of
  variance ``q**2 / (6 dt**2)`` and lag-one correlation -1/2. At a speed constant to
  better than that, the fraction ``f`` is fixed and the error is a periodic pattern (tones,
  as on a real encoder) of variance ``f (1 - f) q**2 / dt**2``, whose mean over ``f`` is
  again ``q**2 / 6``. Either way the error integrates to ``e[k] - e[-1]``: the angle
  stays within one count. The record holds ``speed + error``: the difference quotient
  referred to the middle of its interval, so the half-sample delay of a backward
  difference (a phase of ``-omega dt / 2``, 11 degrees at 300 Hz and 5 kHz) does not
  enter the signal as a sensor bias that no model of the bench has.

Tachometer pulse-time jitter is drawn in :func:`gbpipe.simulate.tacho.pulse_times`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from gbpipe.kinematics import pulsating_orders

__all__ = ["MOTORS", "MOTOR_ANGLE", "broadband_ripple", "pulsating_torque",
           "quantisation_noise"]

#: Motors in the order of the bench's disturbance inputs.
MOTORS = ("driver", "driven")
#: Angle output [rad] of the HSS each motor turns with.
MOTOR_ANGLE = {"driver": "angle_gb2_hss", "driven": "angle_gb1_hss"}


def broadband_ripple(ripple: Mapping[str, Any], rng: np.random.Generator,
                     n: int) -> np.ndarray:
    """White motor torque ripple [N·m], shape (n, 2): driver, then driven column.

    Parameters
    ----------
    ripple : mapping
        ``noise.motor_ripple``: per motor ``broadband`` [N·m rms].
    rng : numpy.random.Generator
        Source of the draws (the driver's ``n`` normals first, then the driven's).
    n : int
        Samples.
    """
    return np.column_stack([rng.standard_normal(n) * float(ripple[m]["broadband"])
                            for m in MOTORS])


def pulsating_torque(ripple: Mapping[str, Any], angles: Mapping[str, np.ndarray],
                     rng: np.random.Generator) -> np.ndarray:
    """Converter pulsating torque [N·m] locked to the motor shaft angles, shape (n, 2).

    Parameters
    ----------
    ripple : mapping
        ``noise.motor_ripple``: per motor ``pole_pairs`` and ``pulsating`` (list of
        ``harmonic`` of the electrical frequency and ``amplitude`` [N·m]).
    angles : mapping
        ``angle_gb1_hss`` and ``angle_gb2_hss`` [rad], equal lengths.
    rng : numpy.random.Generator
        Phases, drawn uniform on [0, 2 pi) for every configured harmonic of the driver,
        then of the driven motor, whatever its amplitude (so a zero amplitude changes
        no other phase).

    Returns
    -------
    ndarray
        ``sum_h A_h sin(h p theta + phi_h)`` for each motor, columns driver, driven.
    """
    n = next(iter(angles.values())).size
    out = np.zeros((n, len(MOTORS)))
    for j, m in enumerate(MOTORS):
        spec = ripple[m]
        phases = rng.uniform(0.0, 2 * np.pi, len(spec["pulsating"]))
        theta = angles[MOTOR_ANGLE[m]]
        for (order, amplitude), ph in zip(pulsating_orders(spec), phases, strict=True):
            out[:, j] += amplitude * np.sin(order * theta + ph)
    return out


def quantisation_noise(angle: np.ndarray, speed0: float, dt: float,
                       counts_per_rev: int) -> np.ndarray:
    """Error [rad/s] of a speed differenced from an encoder-quantised angle.

    Parameters
    ----------
    angle : ndarray, shape (n,)
        True shaft angle [rad] at the samples.
    speed0 : float
        Speed [rad/s] at the first sample: the angle one sample before the record is
        ``angle[0] - speed0 dt``, so the first sample has a difference too.
    dt : float
        Sample interval [s].
    counts_per_rev : int
        Encoder counts per revolution (quantisation step ``2 pi / counts_per_rev`` rad).

    Returns
    -------
    ndarray, shape (n,)
        ``(e[k] - e[k-1]) / dt`` with ``e = floor(angle / q) q - angle`` (a counter
        reports whole counts).
    """
    q = 2 * np.pi / int(counts_per_rev)
    theta = np.concatenate(([angle[0] - speed0 * dt], angle))
    # the encoder's zero is arbitrary: count from the first angle
    rel = theta - theta[0]
    err = np.floor(rel / q) * q - rel
    return np.diff(err) / dt
