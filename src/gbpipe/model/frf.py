"""Batched FRFs of the bench's identification pairings, fast enough for a fitting loop.

:func:`gbpipe.model.truth_model` builds each pairing's closed-loop state space (26 states)
and :func:`gbpipe.lti.frf` solves it per frequency: about 40 ms for the five default
pairings on 240 frequencies. A least-squares fit evaluates the model thousands of times,
so this module takes a shorter, equally exact path:

1. the open-loop plant is a mechanism with states ``[q, q̇]``, so its FRF is one batched
   solve of the n = 12 coordinate equations ``(s² I − s A₂₂ − A₂₁) X = B₂`` (``A₂₁ = −M⁻¹K``,
   ``A₂₂ = −M⁻¹C``, ``B₂ = M⁻¹B_q``: the same matrices, half the size), for both motor
   torques at once;
2. the loops of the controlled motors outside the pairing are closed on that FRF in the
   frequency domain: such a motor applies ``−K(s)·m`` with its PI law
   ``K(s) = k_p + k_i/s`` on its measurement ``m`` (the paper's driver: its own speed;
   driven: the driven torque meter), so

   ``G_cl = G_yS − G_yO (I + K·G_mO)⁻¹ K·G_mS``

   (``S`` the pairing's motors, ``O`` the others, ``K`` diagonal). Set-point weight and
   feed-forward act on the references only, which are not inputs of a pairing.

The result equals ``frf(truth_model(cfg, inputs, outputs), f)`` to round-off (tested to
1e-9 relative), at about 2 ms for all pairings. See docs/fit.md.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from gbpipe.errors import ConfigError
from gbpipe.lti import NamedSS
from gbpipe.model.assembly import bench_chain
from gbpipe.model.chain import Chain, Motor
from gbpipe.model.statespace import chain_plant

__all__ = ["Pairing", "MOTOR_INPUTS", "mechanical_frf", "plant_frf", "close_loops_frf",
           "pairing_frf"]

#: The paper bench's two plant inputs a pairing may use [N·m] (the recorded motor
#: torques); any drivetrain: ``motor_torque_<motor>`` of its motors.
MOTOR_INPUTS = ("motor_torque_driver", "motor_torque_driven")


@dataclass(frozen=True)
class Pairing:
    """Inputs and outputs of one identification pairing (``identify.pairings`` entry).

    Attributes
    ----------
    name : str
        E.g. ``Tdrv_to_wdrv``.
    inputs : tuple of str
        Motor torques ``motor_torque_<motor>`` [N·m] (the paper: one or both of
        :data:`MOTOR_INPUTS`).
    outputs : tuple of str
        Outputs of the open-loop bench (:func:`gbpipe.model.bench_ss` with
        ``closed=False``), e.g. ``speed_gb2_hss`` [rad/s], ``torque_meter_driven`` [N·m].
    """

    name: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]

    def __post_init__(self) -> None:
        ins = list(self.inputs)
        if (not ins or len(set(ins)) != len(ins)
                or any(not u.startswith("motor_torque_") for u in ins)):
            raise ConfigError(f"pairing {self.name}.inputs",
                              f"{ins} must be motor torques motor_torque_<motor>, each once "
                              f"(the paper: {', '.join(MOTOR_INPUTS)})")
        if not self.outputs:
            raise ConfigError(f"pairing {self.name}.outputs", "name at least one output")

    @classmethod
    def from_config(cls, entry: Mapping[str, Any]) -> Pairing:
        """From one ``identify.pairings`` entry (``name``, ``inputs``, ``outputs``)."""
        return cls(str(entry["name"]), tuple(entry["inputs"]), tuple(entry["outputs"]))


def mechanical_frf(ss: NamedSS, f_hz: Any) -> np.ndarray:
    """FRF of a mechanism's state space (states ``[q, q̇]``) by the second-order solve.

    Parameters
    ----------
    ss : NamedSS
        Continuous state space as :func:`gbpipe.model.statespace.mechanism_ss` builds it:
        ``A = [[0, I], [A₂₁, A₂₂]]``, ``B = [[0], [B₂]]``.
    f_hz : array_like
        Frequencies [Hz].

    Returns
    -------
    ndarray
        Complex FRF on (frequency, output, input), in output units per input unit; equal
        to :func:`gbpipe.lti.frf` of ``ss``.

    Raises
    ------
    ValueError
        ``ss`` is not of that form (e.g. a closed loop with controller states).
    """
    a, b, c, d = ss.A, ss.B, ss.C, ss.D
    n = a.shape[0] // 2
    if (a.shape[0] != 2 * n or np.any(a[:n, :n]) or not np.array_equal(a[:n, n:], np.eye(n))
            or np.any(b[:n])):
        raise ValueError("mechanical_frf needs a mechanism state space with states [q, q'] "
                         "(gbpipe.model.bench_ss(cfg, closed=False) or gearbox_ss); use "
                         "gbpipe.lti.frf for other systems")
    s = 2j * np.pi * np.atleast_1d(np.asarray(f_hz, dtype=float)).ravel()
    # z = s² I − s A₂₂ − A₂₁ with s = jω: real part −ω² I − A₂₁, imaginary part −ω A₂₂,
    # built in real arithmetic (the same numbers as the complex products, in a fraction of
    # the time: this is the inner loop of a fit)
    w = s.imag
    z = np.empty((s.size, n, n), dtype=complex)
    z.real = -a[n:, :n]
    diagonal = np.arange(n)
    z.real[:, diagonal, diagonal] -= w[:, None] ** 2
    z.imag = w[:, None, None] * -a[n:, n:]
    x = np.linalg.solve(z, np.broadcast_to(b[n:], (s.size, n, b.shape[1])))
    return c[:, :n] @ x + s[:, None, None] * (c[:, n:] @ x) + d


def plant_frf(cfg: Mapping[str, Any], f_hz: Any, outputs: Sequence[str]) -> np.ndarray:
    """FRF of the open-loop bench from every motor torque to ``outputs``.

    Parameters
    ----------
    cfg : mapping
        Validated configuration (``gearbox``, ``bench``, or ``drivetrain``).
    f_hz : array_like
        Frequencies [Hz].
    outputs : sequence of str
        Open-loop bench outputs.

    Returns
    -------
    ndarray, complex, shape (n_freq, len(outputs), n_motors)
        Inputs ``motor_torque_<motor>`` in motor order (the paper: :data:`MOTOR_INPUTS`;
        the driven one is the braking torque).
    """
    return _chain_plant_frf(bench_chain(cfg), f_hz, outputs)


def _chain_plant_frf(chain: Chain, f_hz: Any, outputs: Sequence[str]) -> np.ndarray:
    plant = chain_plant(chain).select([m.input for m in chain.motors], list(outputs))
    return mechanical_frf(plant, f_hz)


def close_loops_frf(g: np.ndarray, outputs: Sequence[str], pairing: Pairing,
                motors: Sequence[Motor], f_hz: Any) -> np.ndarray:
    """A pairing's FRF from the open-loop plant FRF: the other motors' loops closed.

    Parameters
    ----------
    g : ndarray, complex, shape (n_freq, len(outputs), len(motors))
        :func:`plant_frf` on ``outputs``, which must hold the pairing's outputs and the
        measurement of every controlled motor outside the pairing (the paper:
        ``speed_driver_motor``, ``torque_meter_driven``).
    outputs : sequence of str
        Names of the rows of ``g``.
    pairing : Pairing
    motors : sequence of Motor
        The bench's motors (:attr:`gbpipe.model.chain.Chain.motors`), the columns of ``g``.
    f_hz : array_like
        The frequencies of ``g`` [Hz] (nonzero).

    Returns
    -------
    ndarray, complex, shape (n_freq, n_outputs, n_inputs)
        As :func:`gbpipe.lti.frf` of :func:`gbpipe.model.truth_model`.
    """
    outputs = list(outputs)
    rows = [outputs.index(o) for o in pairing.outputs]
    cols = {m.input: j for j, m in enumerate(motors)}
    ks = [cols[u] for u in pairing.inputs]
    gy = g[:, rows][:, :, ks]
    others = [(j, m) for j, m in enumerate(motors)
              if m.input not in pairing.inputs and m.controller.type != "none"]
    if not others:
        return gy
    ko = [j for j, _ in others]
    ms = [outputs.index(m.controller.sensor) for _, m in others]
    s = 2j * np.pi * np.asarray(f_hz, dtype=float).ravel()
    k = np.stack([m.controller.kp + m.controller.ki / s for _, m in others], axis=1)
    # the other motors' torques are −K·m: solve (I + K G_mO) τ = −K G_mS u, then y
    g_mo = g[:, ms][:, :, ko]
    lhs = np.eye(len(ko)) + k[:, :, None] * g_mo
    rhs = k[:, :, None] * g[:, ms][:, :, ks]
    # one loop to close (the paper's bench): a division, a fifth of a batched 1x1 solve
    tau = rhs / lhs if len(ko) == 1 else np.linalg.solve(lhs, rhs)
    return gy - g[:, rows][:, :, ko] @ tau


def pairing_frf(cfg: Mapping[str, Any], pairings: Sequence[Pairing],
                f_hz: Any) -> list[np.ndarray]:
    """FRFs of the pairings' true models (as :func:`gbpipe.model.truth_model`), batched.

    Parameters
    ----------
    cfg : mapping
        Validated configuration (``gearbox``, ``bench``, or ``drivetrain``).
    pairings : sequence of Pairing
    f_hz : array_like
        Frequencies [Hz], nonzero.

    Returns
    -------
    list of ndarray, complex, shape (n_freq, n_outputs, n_inputs)
        One per pairing, in output units per input unit (rad/s per N·m for speeds).
    """
    f = np.atleast_1d(np.asarray(f_hz, dtype=float)).ravel()
    chain = bench_chain(cfg)
    motors = chain.motors
    outputs = list(dict.fromkeys([o for p in pairings for o in p.outputs]
                                 + [m.controller.sensor for m in motors
                                    if m.controller.type != "none"]))
    g = _chain_plant_frf(chain, f, outputs)
    # a pairing is some rows of its inputs' closed loop: close the loops once per input
    # set, on every output, for all the pairings that share it (the same numbers, fewer
    # operations)
    closed: dict[tuple[str, ...], np.ndarray] = {}
    for p in pairings:
        if p.inputs not in closed:
            closed[p.inputs] = close_loops_frf(g, outputs, Pairing("all", p.inputs,
                                                               tuple(outputs)), motors, f)
    return [closed[p.inputs][:, [outputs.index(o) for o in p.outputs]] for p in pairings]
