"""The closed-loop state of a bench or drivetrain in steady rotation (record start)."""

from __future__ import annotations

import numpy as np
from scipy.linalg import null_space

from gbpipe.errors import StageError
from gbpipe.lti import NamedSS

__all__ = ["steady_state"]


def steady_state(ss: NamedSS, u0: np.ndarray, omega0: float, *,
                 speed_output: str | None = None,
                 zero_angle: str | None = "angle_gb1_hss") -> np.ndarray:
    """Closed-loop state in steady rotation at ``omega0`` [rad/s] under inputs ``u0``.

    Every derivative but the angles' is zero and every body turns at its kinematic share
    of the rigid-body mode of the stiffness matrix, scaled so that the reference turns at
    ``omega0``.

    Parameters
    ----------
    ss : NamedSS
        Closed loop with states ``angle[...]`` [rad], ``speed[...]`` [rad/s], then others.
    u0 : ndarray
        Its inputs held [rad/s, N·m, rad].
    omega0 : float
        Speed [rad/s] of the reference: the state ``angle[driver_motor]`` (the paper's
        bench), or the output ``speed_output``.
    speed_output : str, optional
        A speed output of ``ss`` that turns at ``omega0`` (a drivetrain's speed-loop sensor).
    zero_angle : str or None, default "angle_gb1_hss"
        An angle output held at 0 [rad]; None: the rigid angle of least norm.

    Raises
    ------
    StageError
        Not exactly one rigid-body mode, or no steady state (inputs that accelerate); the
        campaign's load checks refuse such drivetrains first.
    """
    n_q = sum(s.startswith("angle[") for s in ss.states)
    n = ss.A.shape[0]
    K = -ss.A[n_q:2 * n_q, :n_q]          # M⁻¹K: same null space as K
    rigid = null_space(K)
    if rigid.shape[1] != 1:
        raise StageError(f"expected one rigid-body mode, found {rigid.shape[1]}")
    if speed_output is None:
        r = rigid[:, 0] / rigid[ss.states.index("angle[driver_motor]"), 0]
    else:
        # a speed sensor's row reads the speed states: its gain on the rigid mode
        r = rigid[:, 0] / (ss.C[ss.outputs.index(speed_output), n_q:2 * n_q] @ rigid[:, 0])
    select_speeds = np.hstack([np.zeros((n_q, n_q)), np.eye(n_q), np.zeros((n_q, n - 2 * n_q))])
    rows = [ss.A[n_q:], select_speeds]
    rhs = [-ss.B[n_q:] @ u0, omega0 * r]
    if zero_angle is not None:
        rows.append(ss.C[[ss.outputs.index(zero_angle)]])
        rhs.append(np.zeros(1))
    E, b = np.vstack(rows), np.concatenate(rhs)
    x0, *_ = np.linalg.lstsq(E, b, rcond=None)
    resid = np.abs(E @ x0 - b).max()
    if resid > 1e-6 * max(1.0, np.abs(b).max()):
        raise StageError(f"no steady state found (residual {resid:.3g})")
    return x0
