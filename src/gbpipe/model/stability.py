"""Refusal of controller gains that make the closed-loop bench unstable, by name."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from gbpipe.errors import UnstableGain
from gbpipe.model.assembly import bench_chain
from gbpipe.model.chain import Motor
from gbpipe.model.statespace import chain_plant, close_loops

__all__ = ["check_stability", "is_unstable"]


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


def _zero_integrators(motors: list[Motor], gains: Mapping[str, tuple[float, float]]) -> int:
    """Eigenvalues at 0 expected from the rigid body and the integrators with ki = 0."""
    return 1 + sum(gains.get(m.name, (m.controller.kp, m.controller.ki))[1] == 0
                   for m in motors if m.controller.type != "none")


def _controller_path(cfg: Mapping[str, Any], m: Motor) -> str:
    """Key path of a motor's controller in the config."""
    if cfg.get("drivetrain"):
        return f"drivetrain.motors[{m.index}].controller"
    return f"bench.{m.controller.type}_controller"


def check_stability(cfg: Mapping[str, Any]) -> None:
    """Raise :class:`gbpipe.errors.UnstableGain` if the PI gains destabilise the bench.

    An integral gain of 0 (a P controller) is allowed: its integrator state is then an
    uncoupled eigenvalue at 0, not an instability. The gains to blame are found by
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
    if not is_unstable(A, _zero_integrators(motors, {})):
        return
    trials = {}
    for m in motors:
        kp, ki = m.controller.kp, m.controller.ki
        path = _controller_path(cfg, m)
        lower = kp * 0.01 if m.controller.type == "speed" else 0.0
        trials[f"{path}.kp"] = {m.name: (lower, ki)}
        trials[f"{path}.ki"] = {m.name: (kp, 0.0)}
    culprits = [
        name for name, gains in trials.items()
        if not is_unstable(close_loops(plant, chain.motors, gains).A,
                           _zero_integrators(motors, gains))
    ] or list(trials)
    ev = np.linalg.eigvals(A)
    worst = ev[np.argmax(ev.real)]
    others = f" (with {', '.join(culprits[1:])})" if culprits[1:] else ""
    raise UnstableGain(
        culprits[0],
        f"gain makes the closed-loop bench unstable{others}: pole at {worst.real:.3g} ± "
        f"{abs(worst.imag):.3g}j rad/s ({abs(worst.imag) / 2 / np.pi:.1f} Hz); lower it: "
        "integral action on the measured shaft torque acts as negative damping",
    )
