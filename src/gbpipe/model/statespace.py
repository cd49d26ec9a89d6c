"""Named state-space matrices of mechanisms, open loop and with the bench's PI loops.

Matrices are built with numpy only (cheap: config validation checks closed-loop stability
without importing python-control) as :class:`gbpipe.lti.NamedSS`;
:func:`gbpipe.lti.control_io.to_control` wraps them in a named ``control.StateSpace`` at
the public boundary (:mod:`gbpipe.model.control_models`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from gbpipe.lti import NamedSS
from gbpipe.model.mechanics import Mechanism

__all__ = ["mechanism_ss", "close_bench_loops"]


def mechanism_ss(mech: Mechanism, torque_inputs: Mapping[str, tuple[str, float]],
                 error_inputs: Mapping[str, str], speed_outputs: Mapping[str, str],
                 torque_outputs: Mapping[str, tuple[str, float]],
                 angle_outputs: Mapping[str, str] | None = None) -> NamedSS:
    """State space of a mechanism with states ``[q, q̇]``.

    Parameters
    ----------
    mech : Mechanism
    torque_inputs : mapping
        Input name → (body, sign): a torque [N·m] on a body.
    error_inputs : mapping
        Input name → spring: a prescribed angle error [rad] added to the spring's twist
        (transmission error of a rigid mesh, misalignment of a coupling).
    speed_outputs : mapping
        Output name → body: its angular speed [rad/s].
    torque_outputs : mapping
        Output name → (spring, sign): the spring's torque [N·m] including damping and any
        angle error input on it.
    angle_outputs : mapping, optional
        Output name → body: its angle [rad].
    """
    # the index maps and twist maps once for everything below (a fit builds this per
    # model evaluation)
    idx = mech.body_index
    twist = mech.twist_maps()
    M = mech.mass_matrix
    K, Cd = mech.spring_matrices(twist)
    n = len(mech.coords)
    Minv = np.linalg.inv(M)
    Bq = np.column_stack(
        [mech.torque_input(b, s) for b, s in torque_inputs.values()]
        + mech.angle_error_inputs(list(error_inputs.values()), twist)
    ) if (torque_inputs or error_inputs) else np.zeros((n, 0))
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -Minv @ K
    A[n:, n:] = -Minv @ Cd
    B = np.vstack([np.zeros_like(Bq), Minv @ Bq])
    inputs = list(torque_inputs) + list(error_inputs)
    angle_outputs = angle_outputs or {}
    outputs = list(speed_outputs) + list(torque_outputs) + list(angle_outputs)
    C = np.zeros((len(outputs), 2 * n))
    D = np.zeros((len(outputs), len(inputs)))
    for i, body in enumerate(speed_outputs.values()):
        C[i, n:] = mech.T[idx[body]]
    for i, (spring, sign) in enumerate(torque_outputs.values(), start=len(speed_outputs)):
        s, h = mech.spring(spring), twist[spring]
        C[i, :n] = sign * (s.stiffness * h)
        C[i, n:] = sign * (s.damping * h)
        for j, sp in enumerate(error_inputs.values(), start=len(torque_inputs)):
            if sp == spring:
                D[i, j] = sign * s.stiffness
    for i, body in enumerate(angle_outputs.values(),
                             start=len(speed_outputs) + len(torque_outputs)):
        C[i, :n] = mech.T[idx[body]]
    states = [f"angle[{c}]" for c in mech.coords] + [f"speed[{c}]" for c in mech.coords]
    units = {s: ("rad" if s.startswith("angle") else "rad/s") for s in states}
    units.update({u: "N m" for u in torque_inputs})
    units.update({u: "rad" for u in error_inputs})
    units.update({o: "rad/s" for o in speed_outputs})
    units.update({o: "N m" for o in torque_outputs})
    units.update({o: "rad" for o in angle_outputs})
    return NamedSS(A, B, C, D, states, inputs, outputs, units)


def close_bench_loops(plant: NamedSS, bench_cfg: Mapping[str, Any],
                      speed_gains: tuple[float, float] | None = None,
                      torque_gains: tuple[float, float] | None = None) -> NamedSS:
    """Close the bench's two PI loops around the open-loop plant.

    Driver motor (speed loop, on the driver-motor speed ``speed_driver_motor``)::

        T_driver = Kp·(b·ω_ref − ω) + Ki·∫(ω_ref − ω) dt + d_driver

    Driven motor (braking-torque loop, on the driven torque meter)::

        T_brake = ff·T_ref + Kp_t·(T_ref − T_meter) + Ki_t·∫(T_ref − T_meter) dt + d_driven

    Parameters
    ----------
    plant : NamedSS
        Open-loop bench with inputs ``motor_torque_driver``, ``motor_torque_driven``
        first, then excitation inputs.
    bench_cfg : mapping
        ``cfg["bench"]``.
    speed_gains, torque_gains : (kp, ki), optional
        Override the configured gains (used to find which gain makes a loop unstable).

    Returns
    -------
    NamedSS
        Inputs ``speed_ref`` [rad/s], ``torque_ref`` [N·m], ``disturbance_driver``,
        ``disturbance_driven`` [N·m], then the plant's excitation inputs; outputs the
        plant's outputs plus both motor torques; states the plant's plus the two
        controller integrators.
    """
    sc, tc = bench_cfg["speed_controller"], bench_cfg["torque_controller"]
    kp, ki = speed_gains or (float(sc["kp"]), float(sc["ki"]))
    kpt, kit = torque_gains or (float(tc["kp"]), float(tc["ki"]))
    b = float(sc["setpoint_weight"])
    ff = float(tc["feedforward"])
    i_drv, i_brk = plant.index("input", "motor_torque_driver"), plant.index(
        "input", "motor_torque_driven")
    exc = [i for i in range(len(plant.inputs)) if i not in (i_drv, i_brk)]
    cw = plant.C[plant.index("output", "speed_driver_motor")]
    it = plant.index("output", "torque_meter_driven")
    ct, dt_ = plant.C[it], plant.D[it, exc]
    nx, ne = plant.A.shape[0], len(exc)
    # controller outputs as linear maps of [x, z_speed, z_torque] and u_cl
    # u_cl = [speed_ref, torque_ref, d_driver, d_driven, exc...]
    nu = 4 + ne
    Kx = np.zeros((2, nx + 2))
    Ku = np.zeros((2, nu))
    Kx[0, :nx], Kx[0, nx] = -kp * cw, ki
    Ku[0, 0], Ku[0, 2] = kp * b, 1.0
    Kx[1, :nx], Kx[1, nx + 1] = -kpt * ct, kit
    Ku[1, 1], Ku[1, 3] = ff + kpt, 1.0
    Ku[1, 4:] = -kpt * dt_
    Bm = plant.B[:, [i_drv, i_brk]]
    A = np.zeros((nx + 2, nx + 2))
    A[:nx, :nx] = plant.A
    A[:nx] += Bm @ Kx
    A[nx, :nx] = -cw
    A[nx + 1, :nx] = -ct
    B = np.zeros((nx + 2, nu))
    B[:nx] = Bm @ Ku
    B[:nx, 4:] += plant.B[:, exc]
    B[nx, 0] = 1.0
    B[nx + 1, 1] = 1.0
    B[nx + 1, 4:] = -dt_
    Dm = plant.D[:, [i_drv, i_brk]]
    C = np.vstack([np.hstack([plant.C, np.zeros((len(plant.outputs), 2))]) + Dm @ Kx, Kx])
    D = np.vstack([Dm @ Ku, Ku])
    D[:len(plant.outputs), 4:] += plant.D[:, exc]
    inputs = ["speed_ref", "torque_ref", "disturbance_driver", "disturbance_driven"] + [
        plant.inputs[i] for i in exc]
    outputs = plant.outputs + ["motor_torque_driver", "motor_torque_driven"]
    states = plant.states + ["integral_speed_error", "integral_torque_error"]
    units = dict(plant.units)
    units.update(speed_ref="rad/s", torque_ref="N m", disturbance_driver="N m",
                 disturbance_driven="N m", motor_torque_driver="N m",
                 motor_torque_driven="N m", integral_speed_error="rad",
                 integral_torque_error="N m s")
    return NamedSS(A, B, C, D, states, inputs, outputs, units)

