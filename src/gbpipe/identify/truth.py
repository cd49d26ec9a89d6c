"""The true linear model of a signal pairing, with the other loop closed as in the test.

Identification from recorded motor torques to speeds sees the bench *inside* its control
loops. The recorded driver torque is the speed controller's output (plus ripple), so the
system between it and the speeds is the bench with the speed loop opened at the motor
torque and the braking-torque loop still closed; likewise for the driven torque. With
:func:`gbpipe.model.bench_ss` that is:

* ``motor_torque_driver`` alone: speed gains (0, 0); then the input ``disturbance_driver``
  *is* the driver motor torque;
* ``motor_torque_driven`` alone: torque gains (0, 0); ``disturbance_driven`` is the braking
  torque (its feed-forward share of ``torque_ref`` enters through ``torque_ref``, which is
  not an input of the pairing);
* both torques: the open-loop plant.

Zeroed controller integrators stay in the state vector as uncontrollable poles at s = 0:
harmless for FRFs, and excluded from the modal comparison (:func:`true_modes`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from gbpipe.model import bench_ss, frf, modes

__all__ = ["TORQUES", "truth_model", "true_modes", "truth_frf"]

#: FRF of a truth model: ``gbpipe.model.frf`` (direct solve per frequency, exact on the
#: weak cross paths).
truth_frf = frf

#: Motor torques usable as identification inputs -> closed-loop input that equals them when
#: their own loop's gains are zero.
TORQUES = {"motor_torque_driver": "disturbance_driver",
           "motor_torque_driven": "disturbance_driven"}


def truth_model(cfg: Mapping[str, Any], inputs: Sequence[str], outputs: Sequence[str]):
    """True continuous-time model from the pairing's inputs to its outputs.

    Parameters
    ----------
    cfg : mapping
        Validated configuration (``gearbox``, ``bench``).
    inputs : sequence of str
        One or both of ``motor_torque_driver``, ``motor_torque_driven`` [N·m].
    outputs : sequence of str
        Bench outputs, e.g. ``speed_gb1_hss``, ``speed_gb2_hss`` [rad/s].

    Returns
    -------
    gbpipe.model.NamedSS
        Inputs named as in the records (the motor torques), outputs as given.

    Raises
    ------
    ValueError
        An input that is not a motor torque, a repeated input, or an unknown output.
    """

    inputs, outputs = list(inputs), list(outputs)
    bad = [u for u in inputs if u not in TORQUES]
    if bad or not inputs or len(set(inputs)) != len(inputs):
        raise ValueError(f"identify.pairings inputs {inputs} must be one or both of "
                         f"{', '.join(TORQUES)} (each once)")
    if len(inputs) == 2:
        ss = bench_ss(cfg, closed=False).select(inputs, outputs)
    elif inputs[0] == "motor_torque_driver":
        ss = bench_ss(cfg, speed_gains=(0.0, 0.0)).select(["disturbance_driver"], outputs)
    else:
        ss = bench_ss(cfg, torque_gains=(0.0, 0.0)).select(["disturbance_driven"], outputs)
    ss.inputs = inputs
    return ss


def true_modes(A: np.ndarray, f_max: float, zeta_max: float = 0.2
               ) -> tuple[np.ndarray, np.ndarray]:
    """Oscillatory modes of a continuous state matrix below ``f_max`` [Hz].

    Poles at s = 0 (rigid body, zeroed integrators) and real poles are not modes.
    Modes with damping ratio above ``zeta_max`` are left out (not resonances one can see
    in an FRF); a negative damping ratio (a loop that is unstable on its own, see
    :mod:`gbpipe.model`) is kept.

    Returns
    -------
    freq_hz, zeta : ndarray
        Natural frequencies [Hz] (ascending) and damping ratios [-].
    """

    f, z = modes(A)
    keep = (f <= f_max) & (z <= zeta_max)
    return f[keep], z[keep]
