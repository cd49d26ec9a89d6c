"""Batched FRFs of the bench's identification pairings, fast enough for a fitting loop.

:func:`gbpipe.model.truth_model` builds each pairing's closed-loop state space (26 states)
and :func:`gbpipe.lti.frf` solves it per frequency: about 40 ms for the five default
pairings on 240 frequencies. A least-squares fit evaluates the model thousands of times,
so this module takes a shorter, equally exact path:

1. the open-loop plant is a mechanism with states ``[q, q̇]``, so its FRF is one batched
   solve of the n = 12 coordinate equations ``(s² I − s A₂₂ − A₂₁) X = B₂`` (``A₂₁ = −M⁻¹K``,
   ``A₂₂ = −M⁻¹C``, ``B₂ = M⁻¹B_q``: the same matrices, half the size), for both motor
   torques at once;
2. each pairing's other loop is closed on that FRF in the frequency domain: the motor
   outside the pairing applies ``−K(s)·m`` with its PI law ``K(s) = k_p + k_i/s`` on its
   measurement ``m`` (driver: its own speed; driven: the driven torque meter), so

   ``G_cl = G_yu − G_yo · K·G_mu / (1 + K·G_mo)``

   (``u`` the pairing's motor, ``o`` the other one). Set-point weight and feed-forward act
   on the references only, which are not inputs of a pairing.

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
from gbpipe.model.assembly import bench_ss

__all__ = ["Pairing", "MOTOR_INPUTS", "mechanical_frf", "plant_frf", "close_loops",
           "pairing_frf"]

#: The two plant inputs a pairing may use [N·m] (the recorded motor torques).
MOTOR_INPUTS = ("motor_torque_driver", "motor_torque_driven")
# the measurement each motor's own loop feeds back (gbpipe.model.statespace.close_bench_loops)
_LOOP_MEASUREMENT = {"motor_torque_driver": "speed_driver_motor",
                     "motor_torque_driven": "torque_meter_driven"}


@dataclass(frozen=True)
class Pairing:
    """Inputs and outputs of one identification pairing (``identify.pairings`` entry).

    Attributes
    ----------
    name : str
        E.g. ``Tdrv_to_wdrv``.
    inputs : tuple of str
        One or both of :data:`MOTOR_INPUTS` [N·m].
    outputs : tuple of str
        Outputs of the open-loop bench (:func:`gbpipe.model.bench_ss` with
        ``closed=False``), e.g. ``speed_gb2_hss`` [rad/s], ``torque_meter_driven`` [N·m].
    """

    name: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]

    def __post_init__(self) -> None:
        ins = list(self.inputs)
        if not ins or len(set(ins)) != len(ins) or any(u not in MOTOR_INPUTS for u in ins):
            raise ConfigError(f"pairing {self.name}.inputs",
                              f"{ins} must be one or both of {', '.join(MOTOR_INPUTS)}")
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
    """FRF of the open-loop bench from both motor torques to ``outputs``.

    Parameters
    ----------
    cfg : mapping
        Validated configuration (``gearbox``, ``bench``).
    f_hz : array_like
        Frequencies [Hz].
    outputs : sequence of str
        Open-loop bench outputs.

    Returns
    -------
    ndarray, complex, shape (n_freq, len(outputs), 2)
        Inputs in the order of :data:`MOTOR_INPUTS` (the driven one is the braking torque).
    """
    plant = bench_ss(cfg, closed=False).select(list(MOTOR_INPUTS), list(outputs))
    return mechanical_frf(plant, f_hz)


def _pi(cfg_bench: Mapping[str, Any], motor: str, s: np.ndarray) -> np.ndarray:
    ctrl = cfg_bench["speed_controller" if motor == MOTOR_INPUTS[0] else "torque_controller"]
    return float(ctrl["kp"]) + float(ctrl["ki"]) / s


def close_loops(g: np.ndarray, outputs: Sequence[str], pairing: Pairing,
                cfg_bench: Mapping[str, Any], f_hz: Any) -> np.ndarray:
    """A pairing's FRF from the open-loop plant FRF: the other motor's loop closed.

    Parameters
    ----------
    g : ndarray, complex, shape (n_freq, len(outputs), 2)
        :func:`plant_frf` on ``outputs``, which must hold the pairing's outputs and, for a
        one-input pairing, the other loop's measurement (``speed_driver_motor`` or
        ``torque_meter_driven``).
    outputs : sequence of str
        Names of the rows of ``g``.
    pairing : Pairing
    cfg_bench : mapping
        ``cfg["bench"]`` (the PI gains).
    f_hz : array_like
        The frequencies of ``g`` [Hz] (nonzero).

    Returns
    -------
    ndarray, complex, shape (n_freq, n_outputs, n_inputs)
        As :func:`gbpipe.lti.frf` of :func:`gbpipe.model.truth_model`.
    """
    outputs = list(outputs)
    rows = [outputs.index(o) for o in pairing.outputs]
    if len(pairing.inputs) == 2:
        return g[:, rows][:, :, [MOTOR_INPUTS.index(u) for u in pairing.inputs]]
    u = pairing.inputs[0]
    other = MOTOR_INPUTS[1 - MOTOR_INPUTS.index(u)]
    ku, ko = MOTOR_INPUTS.index(u), MOTOR_INPUTS.index(other)
    m = outputs.index(_LOOP_MEASUREMENT[other])
    k = _pi(cfg_bench, other, 2j * np.pi * np.asarray(f_hz, dtype=float).ravel())
    # the other motor's torque is −K·m: solve m = G_mu u − G_mo K m for m, then y
    loop = k * g[:, m, ku] / (1.0 + k * g[:, m, ko])
    return (g[:, rows, ku] - g[:, rows, ko] * loop[:, None])[:, :, None]


def pairing_frf(cfg: Mapping[str, Any], pairings: Sequence[Pairing],
                f_hz: Any) -> list[np.ndarray]:
    """FRFs of the pairings' true models (as :func:`gbpipe.model.truth_model`), batched.

    Parameters
    ----------
    cfg : mapping
        Validated configuration (``gearbox``, ``bench``).
    pairings : sequence of Pairing
    f_hz : array_like
        Frequencies [Hz], nonzero.

    Returns
    -------
    list of ndarray, complex, shape (n_freq, n_outputs, n_inputs)
        One per pairing, in output units per input unit (rad/s per N·m for speeds).
    """
    f = np.atleast_1d(np.asarray(f_hz, dtype=float)).ravel()
    outputs = list(dict.fromkeys([o for p in pairings for o in p.outputs]
                                 + list(_LOOP_MEASUREMENT.values())))
    g = plant_frf(cfg, f, outputs)
    # a one-input pairing is some rows of its input's closed loop: close each loop once, on
    # every output, for all the pairings that share it (the same numbers, fewer operations)
    closed: dict[str, np.ndarray] = {}
    out = []
    for p in pairings:
        if len(p.inputs) == 2:
            out.append(close_loops(g, outputs, p, cfg["bench"], f))
            continue
        u = p.inputs[0]
        if u not in closed:
            closed[u] = close_loops(g, outputs, Pairing(u, (u,), tuple(outputs)),
                                    cfg["bench"], f)
        out.append(closed[u][:, [outputs.index(o) for o in p.outputs]])
    return out
