"""The estimation model of a virtual torque sensor: the chain's discrete state space with
an unknown load and the constant offsets the model cannot explain (docs/virtual.md).

From a built chain (:func:`gbpipe.model.build_chain`) and a choice of measured sensors,
known inputs (the motor torques) and wanted outputs (shaft and mount torques, disk speeds
and angles, held-out sensors):

* states ``[q, q̇]`` of the mechanism (:func:`gbpipe.model.statespace.mechanism_ss`); when
  no angle is measured or wanted, the rigid-body angle (the null space of the stiffness
  matrix, which no twist, speed or torque sees) is removed, so that every state left is
  observable;
* one random-walk state per unknown-load node [N·m] (a torque on the disk the motors'
  measured torques do not account for);
* constant offsets ``b`` (not states: regressors estimated by generalised least squares
  over the whole record, :mod:`gbpipe.virtual.smoother`): a torque offset of each motor
  [N·m] (friction and losses in a torque estimated from the current), then the zero of
  each measured torque sensor [N·m], each kept only where the data can tell it from the
  dynamics and the offsets kept before it (the PBH test at z = 1 of the model with the
  offsets as constant states). A speed or angle offset never is (a rigid-body speed
  explains it); a motor offset needs a measured torque between the motor and the unknown
  loads (else the loads' mean takes it); a sensor's zero and a static torque through the
  chain look alike, so with a motor offset kept the sensor is trusted.

Discretised exactly with the zero-order hold (``scipy.signal.cont2discrete``, the matrix
exponential), the load held over a sample like the inputs.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import linalg
from scipy.signal import cont2discrete

from gbpipe.errors import ConfigError, DataError
from gbpipe.model.chain import Chain
from gbpipe.model.statespace import mechanism_ss

__all__ = ["EstimationModel", "estimation_model", "target_names"]


@dataclass
class EstimationModel:
    """Discrete model ``x+ = A x + B u + Gx b + w``, ``y = C x + D u + Gy b + v``.

    Attributes
    ----------
    dt : float
        Sample interval [s].
    A, B, C, D : ndarray
        Discrete matrices (n, n), (n, m), (p, n), (p, m); states are the mechanism's
        (angles [rad], speeds [rad/s]) then the loads [N·m].
    Gx, Gy : ndarray
        Effect of the offsets on the next state (n, nb) and the measurements (p, nb).
    Cz, Dz : ndarray
        Estimated outputs (r, n), (r, m).
    Bw : ndarray
        Effect (n, n_coords) of a torque [N·m] held over a sample on each independent
        coordinate: the model error's process noise.
    load_states : list of int
        Indices of the random-walk load states.
    states, inputs, measured, targets, offsets : list of str
        Names; ``offsets`` as ``offset_<sensor>`` / ``offset_motor_torque_<motor>``.
    units : dict
        Name → unit of every measured, target and input signal.
    """

    dt: float
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    Gx: np.ndarray
    Gy: np.ndarray
    Cz: np.ndarray
    Dz: np.ndarray
    Bw: np.ndarray
    load_states: list[int]
    states: list[str]
    inputs: list[str]
    measured: list[str]
    targets: list[str]
    offsets: list[str]
    units: dict[str, str]


def target_names(chain: Chain, torques: Sequence[str], speeds: Sequence[str]) -> list[str]:
    """Output names of the wanted shaft/mount torques (``torque_<spring>`` [N·m]) and disk
    speeds (``speed_<disk>`` [rad/s]); an empty ``torques`` means every shaft and mount."""
    springs = [s.name for s in chain.mechanism.springs]
    return ([f"torque_{s}" for s in (torques or springs)]
            + [f"speed_{d}" for d in speeds])


def _sensor_outputs(chain: Chain, names: Sequence[str], where: str
                    ) -> tuple[dict, dict, dict]:
    speed, torque, angle = {}, {}, {}
    for n in names:
        if n in chain.speed_sensors:
            speed[n] = chain.speed_sensors[n]
        elif n in chain.torque_sensors:
            torque[n] = chain.torque_sensors[n]
        elif n in chain.angle_sensors:
            angle[n] = chain.angle_sensors[n]
        else:
            known = [*chain.speed_sensors, *chain.torque_sensors, *chain.angle_sensors]
            raise ConfigError(where, f"{n!r} is not a sensor of the chain; its sensors: "
                              f"{', '.join(known)}")
    return speed, torque, angle


def _observable_rows(A: np.ndarray, C: np.ndarray) -> bool:
    """PBH test at every eigenvalue of ``A`` on or outside the unit circle."""
    n = A.shape[0]
    lam = np.linalg.eigvals(A)
    for z in np.unique(np.round(lam[np.abs(lam) >= 1 - 1e-9], 9)):
        m = np.vstack([A - z * np.eye(n), C])
        # columns equilibrated (rank unchanged): states in rad, rad/s and N·m
        m = m / np.maximum(np.linalg.norm(m, axis=0), 1e-300)
        s = np.linalg.svd(m, compute_uv=False)
        if s[-1] <= 1e-9 * s[0]:
            return False
    return True


def estimation_model(chain: Chain, measured: Sequence[str], targets: Sequence[str],
                     loads: Sequence[str], dt: float, *, offsets: bool = True,
                     where: str = "virtual") -> EstimationModel:
    """The discrete estimation model of a chain (module docstring).

    Parameters
    ----------
    chain : Chain
    measured : sequence of str
        Sensors of the chain the estimator reads (speed [rad/s], torque [N·m], angle [rad]).
    targets : sequence of str
        Wanted outputs: ``torque_<spring>`` [N·m], ``speed_<disk>`` [rad/s],
        ``angle_<disk>`` [rad], or sensor names of the chain (a held-out sensor).
    loads : sequence of str
        Disks an unknown load torque [N·m] acts on (a random walk each).
    dt : float
        Sample interval [s].
    offsets : bool, default True
        Estimate the constant offsets the data can tell apart.
    where : str
        Config key path for errors.

    Raises
    ------
    gbpipe.errors.ConfigError
        An unknown sensor, spring, disk or load node.
    gbpipe.errors.DataError
        The measured sensors cannot observe the chain (e.g. no speed or angle sensor: the
        rigid-body speed is unseen): names them and the fix.
    """
    mech = chain.mechanism
    idx = mech.body_index
    springs = {s.name for s in mech.springs}
    for node in loads:
        if node not in idx:
            raise ConfigError(f"{where}.loads", f"{node!r} is not a disk of the chain; "
                              f"its disks: {', '.join(idx)}")
    m_speed, m_torque, m_angle = _sensor_outputs(chain, measured, f"{where}.sensors")
    t_speed, t_torque, t_angle = {}, {}, {}
    sensors = {*chain.speed_sensors, *chain.torque_sensors, *chain.angle_sensors}
    for t in targets:
        kind, _, name = t.partition("_")
        if t in measured:
            raise ConfigError(f"{where}.holdout", f"{t!r} is both measured and estimated: "
                              "hold it out of virtual.sensors")
        if t in sensors:   # a held-out sensor: its own node or spring and sign
            s, tq, a = _sensor_outputs(chain, [t], f"{where}.holdout")
            t_speed.update(s), t_torque.update(tq), t_angle.update(a)
        elif kind == "torque" and name in springs:
            t_torque[t] = (name, 1.0)
        elif kind in ("speed", "angle") and name in idx:
            (t_speed if kind == "speed" else t_angle)[t] = name
        else:
            raise ConfigError(f"{where}.torques", f"{t!r} is no target of the chain: give "
                              f"torque_<shaft or mount> ({', '.join(sorted(springs))}), "
                              f"speed_<disk> or angle_<disk> ({', '.join(idx)}), or a sensor")
    motors = {m.input: (m.node, m.sign) for m in chain.motors}
    load_in = {f"load_{n}": (n, 1.0) for n in loads}
    ss = mechanism_ss(mech, {**motors, **load_in}, {}, {**m_speed, **t_speed},
                      {**m_torque, **t_torque}, {**m_angle, **t_angle})
    nq = len(mech.coords)
    A, B, C = ss.A, ss.B, ss.C
    # a torque on every independent coordinate: what the model leaves out
    Bw = np.vstack([np.zeros((nq, nq)), np.linalg.inv(mech.mass_matrix)])
    if not (m_angle or t_angle):
        # the rigid-body angle: no twist, speed or torque sees it; keep the angles in the
        # range of the stiffness matrix (the null space of K is that of every twist map)
        V = linalg.orth(mech.stiffness_matrix)
        P = linalg.block_diag(V.T, np.eye(nq))
        A, B, C, Bw = P @ A @ P.T, P @ B, C @ P.T, P @ Bw
        angle_names = [f"twist_mode[{k}]" for k in range(V.shape[1])]
    else:
        angle_names = ss.states[:nq]
    nm, nl = len(motors), len(loads)
    n_mech = A.shape[0]
    # the loads as random-walk states: x_aug = [x, w], w' = 0 (+ noise in discrete time)
    Ac = np.zeros((n_mech + nl, n_mech + nl))
    Ac[:n_mech, :n_mech] = A
    Ac[:n_mech, n_mech:] = B[:, nm:]
    Bc = np.vstack([np.hstack([B[:, :nm], Bw]), np.zeros((nl, nm + nq))])
    Ad, Bd, *_ = cont2discrete((Ac, Bc, np.eye(len(Ac)), np.zeros((len(Ac), nm + nq))), dt,
                               method="zoh")
    Bd, Bwd = Bd[:, :nm], Bd[:, nm:]
    Cfull = np.hstack([C, np.zeros((C.shape[0], nl))])
    D = ss.D[:, :nm]
    mo = [ss.outputs.index(o) for o in measured]
    to = [ss.outputs.index(o) for o in targets]
    Cm, Dm = Cfull[mo], D[mo]
    if not _observable_rows(Ad, Cm):
        raise DataError(where, f"the sensors {', '.join(measured)} cannot observe the "
                        "chain (with its unknown loads): add a speed or angle sensor, or "
                        "fewer virtual.loads")
    # the offsets the data can tell apart: the PBH test with each as a constant state
    gx, gy, names = np.zeros((len(Ad), 0)), np.zeros((len(mo), 0)), []
    # the motors' torques first (an estimate from the current, carrying friction and
    # losses), then the torque sensors' zeros (calibrated): a static torque through the
    # chain and a sensor zero look alike, and the first kept is the one estimated
    candidates = ([(f"offset_{u}", Bd[:, j], Dm[:, j]) for j, u in enumerate(motors)]
                  + [(f"offset_{s}", np.zeros(len(Ad)), np.eye(len(mo))[i])
                     for i, s in enumerate(measured) if s in m_torque])
    for name, cx, cy in (candidates if offsets else []):
        tx, ty = np.column_stack([gx, cx]), np.column_stack([gy, cy])
        k = tx.shape[1]
        Ab = np.block([[Ad, tx], [np.zeros((k, len(Ad))), np.eye(k)]])
        if _observable_rows(Ab, np.hstack([Cm, ty])):
            gx, gy, names = tx, ty, [*names, name]
    states = angle_names + ss.states[nq:] + [f"load_{n}" for n in loads]
    units = dict(ss.units)
    units.update({f"load_{n}": "N m" for n in loads})
    return EstimationModel(dt, Ad, Bd, Cm, Dm, gx, gy, Cfull[to], D[to], Bwd,
                           list(range(n_mech, n_mech + nl)), states, list(motors),
                           list(measured), list(targets), names, units)
