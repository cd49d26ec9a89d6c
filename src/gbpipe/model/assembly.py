"""State spaces of one gearbox and of the bench (any drivetrain), from the configuration.

numpy only: these are the functions gbpipe uses internally (config validation, simulation,
truth). The ``control.StateSpace`` forms are in :mod:`gbpipe.model.control_models`.
The bench is the config's ``drivetrain:`` description when it has one, else the paper's
back-to-back bench generated from ``gearbox:`` + ``bench:`` (docs/drivetrain.md); both go
through the one builder :func:`gbpipe.model.chain.build_chain`.
See docs/architecture.md, "Physics".
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from gbpipe.lti import NamedSS
from gbpipe.model.chain import Chain, build_chain
from gbpipe.model.drivetrain import gearbox_chain, paper_chain
from gbpipe.model.statespace import chain_plant, close_loops

__all__ = ["bench_chain", "gearbox_ss", "bench_ss"]


def bench_chain(cfg: Mapping[str, Any]) -> Chain:
    """The bench as a built drivetrain: ``cfg["drivetrain"]`` if given, else the paper's.

    Parameters
    ----------
    cfg : mapping
        Validated configuration (its description checked at load: not again here, where a
        fit evaluates it with every trial parameter set inside its positive bounds).
    """
    if cfg.get("drivetrain"):
        return build_chain(cfg["drivetrain"], check=False)
    return paper_chain(cfg)


def gearbox_ss(cfg: Mapping[str, Any]) -> NamedSS:
    """State space of one gearbox, free at the LSS and HSS ends.

    Parameters
    ----------
    cfg : mapping
        Validated configuration (``gbpipe.config.load``).

    Returns
    -------
    NamedSS
        Inputs ``torque_hss``, ``torque_lss`` [N·m], ``te_mesh<k>`` [rad]; outputs
        ``speed_lss``, ``speed_hss`` [rad/s], ``torque_shaft<k>`` (and ``torque_mount``)
        [N·m]; states ``angle[...]`` [rad] and ``speed[...]`` [rad/s] of the independent
        coordinates. Figure 3 is ``torque_hss → speed_lss``.
    """
    ss = chain_plant(gearbox_chain(cfg))
    names = {"motor_torque_hss": "torque_hss", "motor_torque_lss": "torque_lss"}
    ss.units.update({names[u]: ss.units.pop(u) for u in names})
    ss.inputs = [names.get(u, u) for u in ss.inputs]
    return ss


def bench_ss(cfg: Mapping[str, Any], closed: bool = True, *,
             gains: Mapping[str, tuple[float, float]] | None = None) -> NamedSS:
    """State space of the complete bench (:func:`bench_chain`).

    Parameters
    ----------
    cfg : mapping
        Validated configuration.
    closed : bool, default True
        Close every motor's loop (the paper: the driver's speed loop and the driven
        motor's braking-torque loop).
    gains : mapping, optional
        Motor name → (kp, ki) replacing its configured gains (e.g. zero gains open a loop
        for a truth model).

    Returns
    -------
    NamedSS
        Closed loop (:func:`gbpipe.model.statespace.close_loops`): inputs the references
        (the paper: ``speed_ref`` [rad/s], ``torque_ref`` [N·m]), ``disturbance_<motor>``
        [N·m] (motor torque ripple), the excitation angles [rad] (the paper:
        ``te_gb<g>_mesh<k>``, ``misalign_gb<g>_coupling``); outputs the sensors (the
        paper: speeds [rad/s] of both motors, both HSS, both LSS ends — ``speed_lss`` is
        GB1's —, the torque meters, LSS shaft and mount torques [N·m], HSS angles [rad])
        and ``motor_torque_<motor>`` [N·m]. Open loop: the motor torques
        ``motor_torque_<motor>`` replace references and disturbances.
    """
    chain = bench_chain(cfg)
    plant = chain_plant(chain)
    if not closed:
        return plant
    return close_loops(plant, chain.motors, gains)
