"""The simulated campaign on a described drivetrain (``drivetrain:``, docs/drivetrain.md).

A test record of a chain is simulated like the paper bench's (:mod:`.campaign`): the
closed-loop chain of :func:`gbpipe.model.bench_ss` from its steady state at the first
reference values, the references of :func:`~gbpipe.simulate.designed.designed_reference`.
The chain's one speed-controlled motor follows ``speed_ref`` [rad/s] (at its controller's
speed sensor: ``campaign.nominal.speed_rpm`` and ``campaign.step.speed_rpm`` are that
sensor's rpm), its one torque-controlled motor ``torque_ref`` [N·m] (at its controller's
torque sensor). Every motor's torque carries the broadband ripple of its
``drivetrain.motors[i].ripple`` (process noise).

The record holds the chain's sensors and ``motor_torque_<motor>`` (:func:`chain_signals`),
clean and, measured-like, with ``_measured`` variants: clean plus white sensor noise of
``noise.sensor.<kind>`` (speed [rad/s], torque [N·m], angle [rad], 0 when not given).
With ``tachometer.sensor`` (an angle sensor of the chain), the measured-like record
also holds that shaft's pulse train (``pulse_time``, as on the paper bench). Angle-locked
excitation, pulsating motor torque and encoder quantisation are the paper bench's only
(not simulated on a chain: refused where configured).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.errors import ConfigError
from gbpipe.lti import lsim
from gbpipe.model import bench_chain, bench_ss
from gbpipe.model.chain import Chain, Motor
from gbpipe.model.statespace import loop_names
from gbpipe.simulate.steady import steady_state
from gbpipe.simulate.tacho import pulse_times, tooth_errors

__all__ = ["chain_signals", "chain_loops", "chain_ripple", "simulate_chain"]

#: Record references of a chain: the campaign's two set-point profiles.
_REFERENCES = ("speed", "torque")


def chain_signals(chain: Chain) -> dict[str, tuple[str, str, str]]:
    """Recorded signals of a chain: name -> (unit, long name, sensor kind).

    The speed, torque and angle sensors (description order within each kind), then
    ``motor_torque_<motor>`` of every motor (kind ``torque``).
    """
    out: dict[str, tuple[str, str, str]] = {}
    for name, node in chain.speed_sensors.items():
        out[name] = ("rad/s", f"speed of {node} (sensor {name})", "speed")
    for name, (spring, _) in chain.torque_sensors.items():
        out[name] = ("N m", f"torque in {spring} (sensor {name})", "torque")
    for name, node in chain.angle_sensors.items():
        out[name] = ("rad", f"angle of {node} (sensor {name})", "angle")
    for m in chain.motors:
        out[m.input] = ("N m", f"{m.name} motor torque (on {m.node})", "torque")
    return out


def chain_loops(chain: Chain) -> dict[str, str]:
    """The motor that follows each campaign profile: ``speed``/``torque`` -> motor name.

    Raises
    ------
    ConfigError
        (``drivetrain.motors``) The chain has not exactly one speed- and one
        torque-controlled motor: the campaign has one profile of each.
    """
    loops = loop_names(chain.motors)
    out = {}
    for kind in _REFERENCES:
        named = [m for m, (ref, _) in loops.items() if ref.startswith(f"{kind}_ref")]
        if len(named) != 1:
            raise ConfigError("drivetrain.motors", f"the simulated campaign needs exactly one "
                              f"motor with a {kind} controller (it follows the campaign's "
                              f"{kind} profile); found {len(named)} ({', '.join(named)}): "
                              f"give one motor 'controller: {{type: {kind}, ...}}'")
        out[kind] = named[0]
    _check_rotation(chain, next(m for m in chain.motors if m.name == out["speed"]))
    return out


def _check_rotation(chain: Chain, speed_motor: Motor) -> None:
    # a record starts in steady rotation (gbpipe.simulate.steady): the line must turn as
    # one rigid-body mode, and the speed loop's sensor must see that rotation
    mech = chain.mechanism
    rigid = mech.rigid_modes()
    if rigid.shape[1] != 1:
        raise ConfigError("drivetrain.mounts", f"the drivetrain has {rigid.shape[1]} rigid-body "
                          "modes; a simulated campaign starts in steady rotation and needs "
                          "a line that turns as one (exactly one): a mount on a rotating "
                          "disk (e.g. an openTorsion Disk with k) holds it to the ground: "
                          "mount only housings, rings and torque arms")
    node = chain.speed_sensors.get(speed_motor.controller.sensor)
    gain = 0.0 if node is None else float(mech.T[mech.body_index[node]] @ rigid[:, 0])
    if abs(gain) <= 1e-9 * np.abs(rigid[:, 0]).max():
        raise ConfigError(f"drivetrain.motors[{speed_motor.index}].controller.sensor",
                          f"'{speed_motor.controller.sensor}' on {node} does not turn with "
                          "the line (a housing or grounded node): put the speed loop's "
                          "sensor on a rotating disk")


def chain_ripple(cfg: Mapping[str, Any], chain: Chain) -> dict[str, float]:
    """Broadband torque ripple [N·m rms] of each chain motor, by motor name.

    A chain's motor carries its ripple in its own entry, ``drivetrain.motors[i].ripple``:
    ``noise.motor_ripple`` is the paper bench's (its ``driver`` and ``driven``, which
    ``config/config.yaml`` sets for every run), so it is not read on a chain, and the
    paper's values never stand for a chain motor that happens to share a name.

    Raises
    ------
    ConfigError
        A motor without ``ripple``, naming its key path and the fix.
    """
    out = {}
    for m in chain.motors:
        entry = cfg["drivetrain"]["motors"][m.index]
        if "ripple" not in entry:
            raise ConfigError(f"drivetrain.motors[{m.index}].ripple", "missing: a simulated "
                              f"campaign drives the {m.name} motor's torque with a white "
                              "broadband ripple; give it in N·m rms (0: none), e.g. "
                              "ripple: 0.5")
        out[m.name] = float(entry["ripple"])
    return out


def simulate_chain(cfg: Mapping[str, Any], t: np.ndarray, speed_ref: np.ndarray,
                   torque_ref: np.ndarray, rng: np.random.Generator,
                   measured: bool) -> xr.Dataset:
    """One closed-loop record of the configured drivetrain.

    Parameters
    ----------
    cfg : mapping
        Validated configuration with ``drivetrain``, ``noise``.
    t : ndarray
        Sample times [s], uniform.
    speed_ref : ndarray
        Speed reference [rad/s] of the speed-controlled motor's sensor.
    torque_ref : ndarray
        Torque reference [N·m] of the torque-controlled motor's sensor.
    rng : numpy.random.Generator
        Source of the ripple (motor order, ``t.size`` normals each), then of the sensor
        noise (signal order).
    measured : bool
        Add the ``_measured`` signals.

    Returns
    -------
    xarray.Dataset
        On ``time``: ``speed_ref``, ``torque_ref`` and every signal of
        :func:`chain_signals`, clean and (measured) ``<name>_measured``.
    """
    chain = bench_chain(cfg)
    loops = chain_loops(chain)
    ripple = chain_ripple(cfg, chain)
    signals = chain_signals(chain)
    ss = bench_ss(cfg)
    names = loop_names(chain.motors)
    refs = [names[loops[k]][0] for k in _REFERENCES]
    dist = [f"disturbance_{m.name}" for m in chain.motors]
    main = ss.select([*refs, *dist], list(signals))
    n, dt = t.size, float(t[1] - t[0])
    u = np.column_stack([speed_ref, torque_ref,
                         *(rng.standard_normal(n) * ripple[m.name] for m in chain.motors)])
    u0 = np.concatenate([[speed_ref[0], torque_ref[0]], np.zeros(len(dist))])
    speed_sensor = next(m.controller.sensor for m in chain.motors if m.name == loops["speed"])
    x0 = steady_state(main, u0, float(speed_ref[0]), speed_output=speed_sensor,
                      zero_angle=None)
    y, _ = lsim(main, u, dt, x0)
    ds = xr.Dataset(coords={"time": ("time", t, {"units": "s", "long_name": "time from record "
                                                 "start", "axis": "T"})})
    ds["speed_ref"] = ("time", speed_ref, {"units": "rad/s",
                                           "long_name": f"speed reference of {speed_sensor}"})
    torque_sensor = next(m.controller.sensor for m in chain.motors if m.name == loops["torque"])
    ds["torque_ref"] = ("time", torque_ref, {"units": "N m",
                                             "long_name": f"torque reference of {torque_sensor}"})
    for i, (name, (unit, long_name, _)) in enumerate(signals.items()):
        ds[name] = ("time", y[:, i], {"units": unit, "long_name": f"{long_name}, clean"})
    if measured:
        sensor = cfg["noise"]["sensor"]
        for i, (name, (unit, long_name, kind)) in enumerate(signals.items()):
            value = y[:, i] + float(sensor.get(kind, 0.0)) * rng.standard_normal(n)
            ds[f"{name}_measured"] = ("time", value, {
                "units": unit, "long_name": f"{long_name}, measured-like (sensor noise)"})
        tach = cfg["tachometer"]
        if tach.get("sensor"):
            ds = _tachometer(ds, tach, y[:, list(signals).index(tach["sensor"])], rng)
    ds.attrs["drivetrain"] = str(cfg["drivetrain"].get("name", "drivetrain"))
    return ds


def _tachometer(ds: xr.Dataset, tach: Mapping[str, Any], theta: np.ndarray,
                rng: np.random.Generator) -> xr.Dataset:
    """Add the pulse train of ``tachometer`` on the clean angle ``theta`` [rad] of its
    sensor: tooth spacing errors, clock quantisation and jitter as on the paper bench."""
    ppr = int(tach["pulses_per_rev"])
    spacing = tooth_errors(ppr, float(tach["spacing_error"]), rng)
    t = ds.time.values
    pulses = pulse_times(t, theta - theta[0], ppr, spacing_error_rad=spacing,
                         clock_hz=float(tach["clock_hz"]), rng=rng,
                         jitter_s=float(tach["jitter"]))
    ds["pulse_time"] = ("pulse", pulses, {"units": "s", "long_name": f"tachometer pulse time "
                                          f"({tach['sensor']})"})
    ds = ds.assign_coords(pulse=("pulse", np.arange(pulses.size),
                                 {"units": "1", "long_name": "tachometer pulse number"}))
    ds["tooth_spacing_error"] = ("tooth", spacing, {"units": "rad",
                                                    "long_name": "tachometer tooth spacing error"})
    ds = ds.assign_coords(tooth=("tooth", np.arange(ppr), {"units": "1",
                                                           "long_name": "tachometer tooth"}))
    ds.attrs["pulses_per_rev"] = ppr
    return ds
