"""Torsional models of a multi-stage gearbox and of the back-to-back test bench.

Public API
----------
gearbox(cfg)
    One gearbox, free at both ends: ``control.StateSpace`` from HSS/LSS torques and
    transmission errors to speeds and shaft torques.
bench(cfg, closed=True)
    The complete bench. Closed loop: references, motor-torque disturbances and
    excitation angles in; speeds, angles, torque meters and motor torques out. With
    ``closed=False`` the open-loop plant with the two motor torques as inputs.
check_stability(cfg)
    Refuses controller gains that make the closed-loop bench unstable, naming the gain.
modes(A)
    Natural frequencies [Hz] and damping ratios of a state matrix.
frf(ss, f_hz)
    Frequency response on a grid by direct evaluation.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from gbpipe.kinematics import parse_stages
from gbpipe.model.drivetrain import bench_mechanism, gearbox_mechanism
from gbpipe.model.mechanics import Body, Mechanism, Spring
from gbpipe.model.statespace import NamedSS, close_bench_loops, mechanism_ss, to_control

__all__ = [
    "gearbox", "bench", "gearbox_ss", "bench_ss", "check_stability", "modes", "frf",
    "Mechanism", "Body", "Spring", "NamedSS", "gearbox_mechanism", "bench_mechanism",
    "InstabilityError",
]


class InstabilityError(ValueError):
    """The configured controller gains make the closed-loop bench unstable."""


def gearbox_ss(cfg: Mapping[str, Any]) -> NamedSS:
    """Single-gearbox state space as numpy matrices (see :func:`gearbox`)."""
    mech, ports = gearbox_mechanism(cfg)
    n = len(parse_stages(cfg["gearbox"]["stages"]))
    torques = {"torque_hss": (ports["hss"], 1.0), "torque_lss": (ports["lss"], 1.0)}
    errors = {f"te_mesh{i}": f"shaft{i}" for i in range(1, n + 1)}
    speeds = {"speed_lss": ports["lss"], "speed_hss": ports["hss"]}
    shaft_t = {f"torque_shaft{i}": (f"shaft{i}", 1.0) for i in range(1, n + 1)}
    if cfg["gearbox"]["housing"]["mount"] == "elastic":
        shaft_t["torque_mount"] = ("mount", 1.0)
    return mechanism_ss(mech, torques, errors, speeds, shaft_t)


def gearbox(cfg: Mapping[str, Any]):
    """State-space model of one gearbox, free at the LSS and HSS ends.

    Parameters
    ----------
    cfg : mapping
        Validated configuration (``gbpipe.config.load``).

    Returns
    -------
    control.StateSpace
        Inputs ``torque_hss``, ``torque_lss`` [N·m], ``te_mesh<k>`` [rad]; outputs
        ``speed_lss``, ``speed_hss`` [rad/s], ``torque_shaft<k>`` (and ``torque_mount``)
        [N·m]; states ``angle[...]`` [rad] and ``speed[...]`` [rad/s] of the independent
        coordinates. Figure 3 is ``torque_hss → speed_lss``.
    """
    return to_control(gearbox_ss(cfg), name="gearbox")


def _plant(cfg: Mapping[str, Any]) -> NamedSS:
    mech, p = bench_mechanism(cfg)
    n = len(parse_stages(cfg["gearbox"]["stages"]))
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
    """Bench state space as numpy matrices (see :func:`bench`)."""
    plant = _plant(cfg)
    if not closed:
        return plant
    return close_bench_loops(plant, cfg["bench"], speed_gains, torque_gains)


def bench(cfg: Mapping[str, Any], closed: bool = True):
    """State-space model of the complete back-to-back bench.

    Parameters
    ----------
    cfg : mapping
        Validated configuration.
    closed : bool, default True
        Close the speed loop (driver motor) and the braking-torque loop (driven motor).

    Returns
    -------
    control.StateSpace
        Closed loop: inputs ``speed_ref`` [rad/s], ``torque_ref`` [N·m],
        ``disturbance_driver``/``disturbance_driven`` [N·m] (motor torque ripple),
        ``te_gb<g>_mesh<k>`` and ``misalign_gb<g>_coupling`` [rad] (excitation); outputs
        speeds [rad/s] of both motors, both HSS (``speed_gb1_hss``, ``speed_gb2_hss``),
        both LSS ends (``speed_lss`` is GB1's), the torque meters
        ``torque_meter_driving``/``torque_meter_driven``, the LSS shaft and mount torques
        [N·m], HSS angles [rad], and both motor torques. Open loop: the two motor torques
        replace references and disturbances.
    """
    return to_control(bench_ss(cfg, closed), name="bench" if closed else "bench_plant")


def _unstable(A: np.ndarray, n_integrators: int = 1) -> bool:
    # The rigid-body angle of the bench is a pure integrator (eigenvalue 0 exactly, one of
    # them in closed loop): it is marginal by nature, not a sign of bad gains. A controller
    # integrator whose gain is zeroed (trials below) adds one more such eigenvalue.
    ev = np.linalg.eigvals(A)
    scale = max(1.0, float(np.abs(ev).max()))
    near_zero = np.abs(ev) < 1e-9 * scale
    return bool(near_zero.sum() > n_integrators or np.any(ev[~near_zero].real >= 0))


def check_stability(cfg: Mapping[str, Any]) -> None:
    """Raise :class:`InstabilityError` if the configured PI gains destabilise the bench.

    The gains to blame are found by lowering one gain at a time (an integral or torque
    gain to zero, the speed proportional gain a hundredfold) and keeping those whose
    change alone makes the loop stable; the error names them.
    """
    from gbpipe.config import ConfigError

    if not _unstable(bench_ss(cfg).A):
        return
    sc, tc = cfg["bench"]["speed_controller"], cfg["bench"]["torque_controller"]
    sg, tg = (float(sc["kp"]), float(sc["ki"])), (float(tc["kp"]), float(tc["ki"]))
    trials = {
        "bench.speed_controller.kp": ((sg[0] * 0.01, sg[1]), tg),
        "bench.speed_controller.ki": ((sg[0], 0.0), tg),
        "bench.torque_controller.kp": (sg, (0.0, tg[1])),
        "bench.torque_controller.ki": (sg, (tg[0], 0.0)),
    }
    culprits = [
        name for name, (s_g, t_g) in trials.items()
        if not _unstable(bench_ss(cfg, speed_gains=s_g, torque_gains=t_g).A,
                         1 + (s_g[1] == 0) + (t_g[1] == 0))
    ] or list(trials)
    ev = np.linalg.eigvals(bench_ss(cfg).A)
    worst = ev[np.argmax(ev.real)]
    fields = ", ".join(f"'{c}'" for c in culprits)
    raise type("UnstableGain", (InstabilityError, ConfigError), {})(
        f"config field {fields} makes the closed-loop bench unstable (pole at "
        f"{worst.real:.3g} ± {abs(worst.imag):.3g}j rad/s, {abs(worst.imag) / 2 / np.pi:.1f} Hz);"
        " lower it: integral action on the measured shaft torque acts as negative damping"
    )


def modes(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies and damping ratios of the oscillatory modes of ``A``.

    Returns
    -------
    freq_hz : ndarray
        Undamped natural frequencies |λ|/2π [Hz], ascending, one per conjugate pair.
    zeta : ndarray
        Damping ratios −Re λ/|λ| [-].
    """
    ev = np.linalg.eigvals(A)
    scale = max(1.0, float(np.abs(ev).max()))
    # a free-free chain has a double eigenvalue at 0 that rounding splits into a tiny
    # complex pair: drop everything within 1e-6 of the spectral radius of the origin
    ev = ev[(ev.imag > 1e-9 * scale) & (np.abs(ev) > 1e-6 * scale)]
    wn = np.abs(ev)
    order = np.argsort(wn)
    return wn[order] / (2 * np.pi), -ev.real[order] / wn[order]


def frf(ss: NamedSS, f_hz: np.ndarray) -> np.ndarray:
    """Frequency response ``C (jωI − A)⁻¹ B + D`` on a grid, by direct evaluation.

    One linear solve per frequency, batched: a modal shortcut (diagonalise A once) is
    faster but its eigenvector round-off reaches tenths of a dB on weak cross paths (the
    bench's driving torque -> driven speed is 45 dB below the direct paths), a visible share
    of the 1 dB tolerance of the identification metrics.

    Parameters
    ----------
    ss : NamedSS
    f_hz : array_like
        Frequencies [Hz].

    Returns
    -------
    ndarray, complex, shape (n_freq, n_outputs, n_inputs)
    """
    f = np.atleast_1d(np.asarray(f_hz, dtype=float))
    n = ss.A.shape[0]
    out = np.empty((f.size, ss.C.shape[0], ss.B.shape[1]), dtype=complex)
    for lo in range(0, f.size, 256):  # chunks bound the (chunk, n, n) stack
        s = 2j * np.pi * f[lo:lo + 256]
        M = s[:, None, None] * np.eye(n) - ss.A
        X = np.linalg.solve(M, np.broadcast_to(ss.B, (s.size, *ss.B.shape)))
        out[lo:lo + 256] = ss.C @ X + ss.D
    return out
