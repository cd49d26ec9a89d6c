"""Named state-space matrices of mechanisms, open loop and with their motors' loops.

Matrices are built with numpy only (cheap: config validation checks closed-loop stability
without importing python-control) as :class:`gbpipe.lti.NamedSS`;
:func:`gbpipe.lti.control_io.to_control` wraps them in a named ``control.StateSpace`` at
the public boundary (:mod:`gbpipe.model.control_models`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from gbpipe.lti import NamedSS
from gbpipe.model.chain import Chain, Motor
from gbpipe.model.mechanics import Mechanism

__all__ = ["mechanism_ss", "chain_plant", "loop_names", "close_loops"]


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


def chain_plant(chain: Chain) -> NamedSS:
    """Open-loop state space of a built drivetrain (docs/drivetrain.md, "Plant").

    Inputs ``motor_torque_<motor>`` [N·m] (motor order), then the excitation angles [rad];
    outputs the speed [rad/s], torque [N·m] and angle [rad] sensors.
    """
    return mechanism_ss(chain.mechanism, {m.input: (m.node, m.sign) for m in chain.motors},
                        chain.excitation, chain.speed_sensors, chain.torque_sensors,
                        chain.angle_sensors)


def loop_names(motors: Sequence[Motor]) -> dict[str, tuple[str, str]]:
    """Reference input and integrator state of each controlled motor, by motor name.

    ``speed_ref``/``integral_speed_error`` (``torque_ref``/``integral_torque_error``) when
    exactly one motor has a controller of that type, else suffixed ``_<motor>``
    (docs/drivetrain.md, "Names of the closed-loop signals").
    """
    types = [m.controller.type for m in motors]
    out = {}
    for m in motors:
        t = m.controller.type
        if t == "none":
            continue
        tail = "" if types.count(t) == 1 else f"_{m.name}"
        out[m.name] = (f"{t}_ref{tail}", f"integral_{t}_error{tail}")
    return out


def close_loops(plant: NamedSS, motors: Sequence[Motor],
                gains: Mapping[str, tuple[float, float]] | None = None) -> NamedSS:
    """Close every motor's control loop around the open-loop plant.

    Per motor (torque ``T`` in its own sign, the plant input ``motor_torque_<name>``)::

        speed:  T = kp·(b·ω_ref − ω) + ki·∫(ω_ref − ω) dt + d
        torque: T = ff·T_ref + kp·(T_ref − T_m) + ki·∫(T_ref − T_m) dt + d
        none:   T = d

    with ``d`` the input ``disturbance_<name>`` [N·m] and ``ω`` [rad/s] / ``T_m`` [N·m]
    the controller's sensor (including any excitation feed-through of a torque sensor).

    Parameters
    ----------
    plant : NamedSS
        Open-loop chain (:func:`mechanism_ss`) with inputs ``motor_torque_<name>`` of
        every motor, then excitation inputs.
    motors : sequence of Motor
        :attr:`gbpipe.model.chain.Chain.motors`.
    gains : mapping, optional
        Motor name → (kp, ki) replacing its configured gains (zero gains open a loop for
        a truth model; the stability check lowers one gain at a time).

    Returns
    -------
    NamedSS
        Inputs: the references (:func:`loop_names`, motor order) [rad/s or N·m],
        ``disturbance_<name>`` of every motor [N·m], then the plant's excitation inputs;
        outputs: the plant's, then ``motor_torque_<name>`` [N·m]; states: the plant's, then
        the integrators (``integral_speed_error`` [rad], ``integral_torque_error``
        [N·m·s]).
    """
    gains = gains or {}
    names = loop_names(motors)
    ctrl = [m for m in motors if m.name in names]
    i_m = [plant.index("input", m.input) for m in motors]
    exc = [i for i in range(len(plant.inputs)) if i not in i_m]
    nx, nc, nm, ne = plant.A.shape[0], len(ctrl), len(motors), len(exc)
    nu = nc + nm + ne
    # motor torques as linear maps of [x, z] and u_cl = [refs, disturbances, exc]
    Kx, Ku = np.zeros((nm, nx + nc)), np.zeros((nm, nu))
    Kx_z, Bz = np.zeros((nc, nx + nc)), np.zeros((nc, nu))
    r = 0
    for j, m in enumerate(motors):
        Ku[j, nc + j] = 1.0
        if m.name not in names:
            continue
        c = m.controller
        kp, ki = gains.get(m.name, (c.kp, c.ki))
        b, ff = (c.setpoint_weight, 0.0) if c.type == "speed" else (1.0, c.feedforward)
        im = plant.index("output", c.sensor)
        cm, dm = plant.C[im], plant.D[im, exc]
        Kx[j, :nx], Kx[j, nx + r] = -kp * cm, ki
        Ku[j, r] = ff + kp * b
        Ku[j, nc + nm:] = -kp * dm
        Kx_z[r, :nx] = -cm                 # ż = ref − measurement
        Bz[r, r] = 1.0
        Bz[r, nc + nm:] = -dm
        r += 1
    Bm = plant.B[:, i_m]
    A = np.vstack([np.hstack([plant.A, np.zeros((nx, nc))]) + Bm @ Kx, Kx_z])
    B = np.vstack([Bm @ Ku, Bz])
    B[:nx, nc + nm:] += plant.B[:, exc]
    Dm = plant.D[:, i_m]
    C = np.vstack([np.hstack([plant.C, np.zeros((len(plant.outputs), nc))]) + Dm @ Kx, Kx])
    D = np.vstack([Dm @ Ku, Ku])
    D[:len(plant.outputs), nc + nm:] += plant.D[:, exc]
    refs = [names[m.name][0] for m in ctrl]
    integrators = [names[m.name][1] for m in ctrl]
    inputs = refs + [f"disturbance_{m.name}" for m in motors] + [plant.inputs[i] for i in exc]
    outputs = plant.outputs + [m.input for m in motors]
    units = dict(plant.units)
    for m in ctrl:
        speed = m.controller.type == "speed"
        ref, integ = names[m.name]
        units.update({ref: "rad/s" if speed else "N m", integ: "rad" if speed else "N m s"})
    units.update({f"disturbance_{m.name}": "N m" for m in motors})
    units.update({m.input: "N m" for m in motors})
    return NamedSS(A, B, C, D, plant.states + integrators, inputs, outputs, units)
