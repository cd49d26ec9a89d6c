"""Refusal of controller gains that make the closed-loop bench unstable, by name."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from gbpipe.errors import UnstableGain
from gbpipe.model.assembly import bench_chain
from gbpipe.model.chain import Motor
from gbpipe.model.statespace import chain_plant, close_loops

__all__ = ["check_stability", "is_unstable", "controller_path"]


def is_unstable(A: np.ndarray, n_integrators: int = 1) -> bool:
    """True if ``A`` has an eigenvalue in the open right half-plane, on the imaginary
    axis away from 0, or more than `n_integrators` eigenvalues at 0.

    The rigid-body angle of the bench is a pure integrator (eigenvalue 0 exactly, one in
    closed loop): marginal by nature, not a sign of bad gains. A controller integrator
    whose gain is zero adds one more such eigenvalue, uncoupled and equally harmless;
    callers count those in `n_integrators`.
    """
    ev = np.linalg.eigvals(A)
    scale = max(1.0, float(np.abs(ev).max()))
    near_zero = np.abs(ev) < 1e-9 * scale
    return bool(near_zero.sum() > n_integrators or np.any(ev[~near_zero].real >= 0))


def _null_dimension(A: np.ndarray) -> int:
    """Independent null vectors of ``A``: the eigenvalues at 0 that stay bounded.

    Rigid-body angles, integrators with ki = 0, a speed integrator against a mount: each
    a null vector of its own. Eigenvalues at 0 beyond these form a Jordan block (growth
    like t), which :func:`is_unstable` then refuses. Exact null singular values are at
    round-off (1e-17 of the largest for the paper's bench); the smallest true ones are
    seven decades above, hence the 1e-12 threshold.
    """
    s = np.linalg.svd(A, compute_uv=False)
    return int(np.sum(s <= 1e-12 * s.max()))


def controller_path(cfg: Mapping[str, Any], m: Motor) -> str:
    """Key path of a motor's controller in the config (``drivetrain.motors[i].controller``,
    or the paper bench's ``bench.speed_controller`` / ``bench.torque_controller``)."""
    if cfg.get("drivetrain"):
        return f"drivetrain.motors[{m.index}].controller"
    return f"bench.{m.controller.type}_controller"


def check_stability(cfg: Mapping[str, Any]) -> None:
    """Raise :class:`gbpipe.errors.UnstableGain` if the PI gains destabilise the bench.

    An integral gain of 0 (a P controller) is allowed: its integrator state is then an
    uncoupled eigenvalue at 0, not an instability; likewise every eigenvalue at 0 with its
    own null vector (:func:`_null_dimension`). The gains to blame are found by
    lowering one gain at a time (an integral or torque gain to zero, a speed proportional
    gain a hundredfold) and keeping those whose change alone makes the loop stable; the
    error names them.

    Parameters
    ----------
    cfg : mapping
        Configuration with ``gearbox`` and ``bench`` (defaults applied), or
        ``drivetrain``.

    Raises
    ------
    gbpipe.errors.UnstableGain
        ``field`` is the key path of the first gain to lower, the message names all.
    """
    chain = bench_chain(cfg)
    motors = [m for m in chain.motors if m.controller.type != "none"]
    plant = chain_plant(chain)
    A = close_loops(plant, chain.motors).A
    if not is_unstable(A, _null_dimension(A)):
        return
    trials = {}
    for m in motors:
        kp, ki = m.controller.kp, m.controller.ki
        path = controller_path(cfg, m)
        lower = kp * 0.01 if m.controller.type == "speed" else 0.0
        trials[f"{path}.kp"] = {m.name: (lower, ki)}
        trials[f"{path}.ki"] = {m.name: (kp, 0.0)}
    trial_a = {name: close_loops(plant, chain.motors, gains).A
               for name, gains in trials.items()}
    culprits = [name for name, a in trial_a.items() if not is_unstable(a, _null_dimension(a))]
    ev = np.linalg.eigvals(A)
    worst = ev[np.argmax(ev.real)]
    if not culprits and cfg.get("drivetrain"):
        raise UnstableGain(
            "drivetrain.motors",
            f"the closed loop is unstable (pole at {worst.real:.3g} ± {abs(worst.imag):.3g}j "
            "rad/s) and lowering no single gain helps: a part of the chain whose speed no "
            "speed loop or mount holds drifts; give it a speed-controlled motor or a mount")
    culprits = culprits or list(trials)
    others = f" (with {', '.join(culprits[1:])})" if culprits[1:] else ""
    raise UnstableGain(
        culprits[0],
        f"gain makes the closed-loop bench unstable{others}: pole at {worst.real:.3g} ± "
        f"{abs(worst.imag):.3g}j rad/s ({abs(worst.imag) / 2 / np.pi:.1f} Hz); lower it: "
        "integral action on the measured shaft torque acts as negative damping",
    )
