"""State spaces of one gearbox and of the back-to-back bench, from the configuration.

numpy only: these are the functions gbpipe uses internally (config validation, simulation,
truth). The ``control.StateSpace`` forms are in :mod:`gbpipe.model.control_models`.
See docs/architecture.md, "Physics".
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from gbpipe.lti import NamedSS
from gbpipe.model.drivetrain import bench_mechanism, gearbox_mechanism
from gbpipe.model.statespace import close_bench_loops, mechanism_ss

__all__ = ["gearbox_ss", "bench_ss"]


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
    mech, ports = gearbox_mechanism(cfg)
    n = len(cfg["gearbox"]["stages"])      # parsed (validated) by gearbox_mechanism
    torques = {"torque_hss": (ports["hss"], 1.0), "torque_lss": (ports["lss"], 1.0)}
    errors = {f"te_mesh{i}": f"shaft{i}" for i in range(1, n + 1)}
    speeds = {"speed_lss": ports["lss"], "speed_hss": ports["hss"]}
    shaft_t = {f"torque_shaft{i}": (f"shaft{i}", 1.0) for i in range(1, n + 1)}
    if cfg["gearbox"]["housing"]["mount"] == "elastic":
        shaft_t["torque_mount"] = ("mount", 1.0)
    return mechanism_ss(mech, torques, errors, speeds, shaft_t)


def _plant(cfg: Mapping[str, Any]) -> NamedSS:
    mech, p = bench_mechanism(cfg)
    n = len(cfg["gearbox"]["stages"])      # parsed (validated) by bench_mechanism
    torques = {"motor_torque_driver": ("driver_motor", 1.0),
               "motor_torque_driven": ("driven_motor", -1.0)}   # braking torque
    errors: dict[str, str] = {}
    for gb in ("gb1", "gb2"):
        for i in range(1, n + 1):
            errors[f"te_{gb}_mesh{i}"] = f"{gb}.shaft{i}"
    errors["misalign_gb1_coupling"] = "driven_coupling"
    errors["misalign_gb2_coupling"] = "driver_coupling"
    speeds = {"speed_driver_motor": p["driver_motor"], "speed_gb2_hss": p["gb2_hss"],
              "speed_gb2_lss": p["gb2_lss"], "speed_lss": p["gb1_lss"],
              "speed_gb1_hss": p["gb1_hss"], "speed_driven_motor": p["driven_motor"]}
    torques_out = {"torque_meter_driving": ("driver_coupling", 1.0),
                   "torque_meter_driven": ("driven_coupling", 1.0),
                   "torque_lss_shaft": ("lss_shaft", 1.0)}
    if cfg["gearbox"]["housing"]["mount"] == "elastic":
        torques_out.update(torque_mount_gb1=("gb1.mount", 1.0),
                           torque_mount_gb2=("gb2.mount", 1.0))
    angles = {"angle_gb1_hss": p["gb1_hss"], "angle_gb2_hss": p["gb2_hss"]}
    return mechanism_ss(mech, torques, errors, speeds, torques_out, angles)


def bench_ss(cfg: Mapping[str, Any], closed: bool = True, *,
             speed_gains: tuple[float, float] | None = None,
             torque_gains: tuple[float, float] | None = None) -> NamedSS:
    """State space of the complete back-to-back bench.

    Parameters
    ----------
    cfg : mapping
        Validated configuration.
    closed : bool, default True
        Close the speed loop (driver motor) and the braking-torque loop (driven motor).
    speed_gains, torque_gains : (kp, ki), optional
        Replace the configured PI gains (e.g. zero gains open a loop for a truth model).

    Returns
    -------
    NamedSS
        Closed loop: inputs ``speed_ref`` [rad/s], ``torque_ref`` [N·m],
        ``disturbance_driver``/``disturbance_driven`` [N·m] (motor torque ripple),
        ``te_gb<g>_mesh<k>`` and ``misalign_gb<g>_coupling`` [rad] (excitation); outputs
        speeds [rad/s] of both motors, both HSS (``speed_gb1_hss``, ``speed_gb2_hss``),
        both LSS ends (``speed_lss`` is GB1's), the torque meters
        ``torque_meter_driving``/``torque_meter_driven``, the LSS shaft and mount torques
        [N·m], HSS angles [rad], and both motor torques. Open loop: the two motor torques
        replace references and disturbances.
    """
    plant = _plant(cfg)
    if not closed:
        return plant
    return close_bench_loops(plant, cfg["bench"], speed_gains, torque_gains)
