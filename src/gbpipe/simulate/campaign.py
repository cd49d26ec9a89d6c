"""Closed-loop test campaigns and the speed sweep, clean and measured-like.

Each record is simulated with the closed-loop bench of :func:`gbpipe.model.bench_ss`
from its steady state at the first reference values:

* **clean**: references plus motor torque ripple (process noise: broadband, and the
  converter pulsating torque locked to each motor's shaft angle, :mod:`.noise`);
* **measured-like**: clean plus the bench's response to excitation locked to shaft angle
  (shaft orders as an angle error across each HSS coupling, gear-mesh transmission errors
  with harmonics on the shaft after each stage, amplitudes proportional to the torque
  reference) plus sensor noise, encoder quantisation on the speeds, and the GB1 HSS
  tachometer pulse train (clock quantisation and jitter).

Angle-locked inputs follow the HSS angles of the simulation before them (the pulsating
torque those of the broadband-ripple simulation, the gear excitation the clean ones): the
angle perturbation each adds is micro-radians, so the superposition is exact to that
order and the bench dynamics (the ~62 Hz resonance) shape every line as in a real bench.
A designed test (:mod:`.designed`) is simulated like its base test, from its own
references, and refused when its predicted motor torque exceeds ``bench.torque_limit``.
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr
from scipy.integrate import cumulative_trapezoid

from gbpipe.errors import ExcitationError
from gbpipe.kinematics import order_of, total_ratio
from gbpipe.lti import NamedSS, lsim
from gbpipe.model import bench_chain, bench_ss
from gbpipe.simulate.chain_campaign import simulate_chain
from gbpipe.simulate.designed import (
    check_name,
    designed_reference,
    designed_setpoint,
    designed_spec,
)
from gbpipe.simulate.excitation import within_limits
from gbpipe.simulate.noise import MOTORS, broadband_ripple, pulsating_torque, quantisation_noise
from gbpipe.simulate.profiles import PROFILES, RPM, TESTS, sweep_reference
from gbpipe.simulate.signals import SIGNALS
from gbpipe.simulate.steady import steady_state
from gbpipe.simulate.tacho import pulse_times, tooth_errors

__all__ = ["test", "sweep", "steady_state", "SIGNALS"]

_ANGLES = ("angle_gb1_hss", "angle_gb2_hss")
#: Seconds of excitation simulated before each record (discarded): > 5 time constants of
#: the lightly damped bench modes the harmonics excite.
PREROLL = 2.0
#: Spawn key (under ``seed``) of the pulsating-torque phases: one draw per configuration.
PULSATING_KEY = 1000
_DISTURBANCES = ["disturbance_driver", "disturbance_driven"]


def _overlay(base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    """Nested copy of `base` with the values of `over` replacing its own, key by key."""
    out = dict(base)
    for k, v in over.items():
        both = isinstance(v, Mapping) and isinstance(base.get(k), Mapping)
        out[k] = _overlay(base[k], v) if both else v
    return out


def _rng(seed: int, *key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=key))


def _preroll(y: np.ndarray, outputs: list[str], dt: float) -> tuple[dict[str, np.ndarray],
                                                                      int]:
    """HSS angles [rad] extended back PREROLL seconds at their initial speed.

    Angle-locked inputs run for PREROLL seconds before the record starts, so the record
    holds their steady response, not the transient of switching them on at t = 0.
    """
    n_pre = int(round(PREROLL / dt))
    t_pre = np.arange(-n_pre, 0) * dt
    angles = {}
    for a in _ANGLES:
        th = y[:, outputs.index(a)]
        w0 = y[0, outputs.index(a.replace("angle", "speed"))]
        angles[a] = np.concatenate([th[0] + w0 * t_pre, th])
    return angles, n_pre


def _locked_response(ss: NamedSS, inputs: list[str], outputs: list[str], u: np.ndarray,
                     dt: float, n_pre: int) -> np.ndarray:
    """Response of the outputs to angle-locked inputs from rest, preroll discarded."""
    ye, _ = lsim(ss.select(inputs, outputs), u, dt)
    return ye[n_pre:]


def _excitation(cfg: Mapping[str, Any], names: list[str], angles: dict[str, np.ndarray],
                load: np.ndarray) -> np.ndarray:
    """Excitation input samples [rad], shape (n, len(names)), locked to the HSS angles."""
    exc = cfg["excitation"]
    stages = cfg["gearbox"]["stages"]
    rng = _rng(int(exc["seed"]), 1)
    scale = load / float(exc["load_reference"])
    out = np.zeros((load.size, len(names)))
    for g in ("gb1", "gb2"):
        # phases are drawn for both gearboxes in a fixed order, so selecting gearboxes
        # never changes the other one's phases
        ph_shaft = rng.uniform(0, 2 * np.pi, len(exc["shaft_orders"]))
        ph_mesh = [rng.uniform(0, 2 * np.pi, len(m["harmonics"])) for m in exc["mesh"]]
        if g not in exc["gearboxes"]:
            continue
        theta = angles[f"angle_{g}_hss"]
        col = names.index(f"misalign_{g}_coupling")
        # a line of zero amplitude adds exactly nothing: its sine is not computed (the
        # random-only twins switch every line off; their phases are drawn all the same)
        for s, ph in zip(exc["shaft_orders"], ph_shaft, strict=True):
            if float(s["amplitude"]):
                out[:, col] += float(s["amplitude"]) * np.sin(float(s["order"]) * theta + ph)
        for m, phs in zip(exc["mesh"], ph_mesh, strict=True):
            col = names.index(f"te_{g}_mesh{m['stage']}")
            o = float(order_of(stages, f"mesh{m['stage']}"))
            for h, (w, ph) in enumerate(zip(m["harmonics"], phs, strict=True), start=1):
                if float(m["amplitude"]) * w:
                    out[:, col] += float(m["amplitude"]) * w * np.sin(h * o * theta + ph)
    return out * scale[:, None]


def _simulate(cfg: Mapping[str, Any], t: np.ndarray, speed_ref: np.ndarray,
              torque_ref: np.ndarray, noise_key: tuple[int, ...], measured: bool,
              check: Any = None) -> xr.Dataset:
    ss = bench_ss(cfg)
    n = t.size
    dt = float(t[1] - t[0])
    noise = cfg["noise"]
    seed = int(cfg["seed"])
    rng = _rng(seed, *noise_key)
    ripple = broadband_ripple(noise["motor_ripple"], rng, n)
    outputs = list(SIGNALS) + list(_ANGLES)
    main = ss.select(["speed_ref", "torque_ref", *_DISTURBANCES], outputs)
    u = np.column_stack([speed_ref, torque_ref, ripple])
    x0 = steady_state(main, np.array([speed_ref[0], torque_ref[0], 0.0, 0.0]), speed_ref[0])
    y, _ = lsim(main, u, dt, x0)
    angles, n_pre = _preroll(y, outputs, dt)
    pulsating = pulsating_torque(noise["motor_ripple"], angles, _rng(seed, PULSATING_KEY))
    if np.any(pulsating):
        y = y + _locked_response(ss, _DISTURBANCES, outputs, pulsating, dt, n_pre)
    ds = xr.Dataset(coords={"time": ("time", t, {"units": "s", "long_name": "time from record "
                                                 "start", "axis": "T"})})
    ds["speed_ref"] = ("time", speed_ref, {"units": "rad/s", "long_name": "HSS speed reference"})
    ds["torque_ref"] = ("time", torque_ref, {"units": "N m",
                                             "long_name": "braking torque reference at HSS"})
    for i, (name, (unit, long_name, _)) in enumerate(SIGNALS.items()):
        ds[name] = ("time", y[:, i], {"units": unit, "long_name": f"{long_name}, clean"})
    if check is not None:
        check(ss, ds)
    if not measured:
        return ds
    exc_names = [s for s in ss.inputs if s.startswith(("te_", "misalign_"))]
    angles, n_pre = _preroll(y, outputs, dt)
    load = np.concatenate([np.full(n_pre, torque_ref[0]), torque_ref])
    e = _excitation(cfg, exc_names, angles, load)
    # no excitation (a random-only twin): its response from rest is exactly zero
    ym = y + _locked_response(ss, exc_names, outputs, e, dt, n_pre) if np.any(e) else y
    sensor = noise["sensor"]
    for i, (name, (unit, long_name, kind)) in enumerate(SIGNALS.items()):
        value = ym[:, i] + float(sensor[kind]) * rng.standard_normal(n)
        if kind == "speed":
            value += quantisation_noise(_angle(ym, outputs, name, dt), ym[0, i], dt,
                                        int(noise["encoder"]["counts_per_rev"]))
        ds[f"{name}_measured"] = ("time", value, {
            "units": unit, "long_name": f"{long_name}, measured-like (harmonics + sensor "
                                        "noise)"})
    tach = cfg["tachometer"]
    theta = ym[:, outputs.index("angle_gb1_hss")]
    omega = ym[:, outputs.index("speed_gb1_hss")]
    ppr = int(tach["pulses_per_rev"])
    spacing = tooth_errors(ppr, float(tach["spacing_error"]),
                           _rng(int(cfg["excitation"]["seed"]), 2))
    pulses = pulse_times(t, theta - theta[0], ppr, speed=omega, spacing_error_rad=spacing,
                         clock_hz=float(tach["clock_hz"]), rng=_rng(seed, *noise_key, 1),
                         jitter_s=float(tach["jitter"]))
    ds["pulse_time"] = ("pulse", pulses, {"units": "s", "long_name": "GB1 HSS tachometer "
                                          "pulse time"})
    ds = ds.assign_coords(pulse=("pulse", np.arange(pulses.size),
                                 {"units": "1", "long_name": "tachometer pulse number"}))
    ds.attrs["pulses_per_rev"] = ppr
    ds["tooth_spacing_error"] = ("tooth", spacing, {"units": "rad",
                                                    "long_name": "tachometer tooth spacing error"})
    ds = ds.assign_coords(tooth=("tooth", np.arange(ppr), {"units": "1",
                                                           "long_name": "tachometer tooth"}))
    ds["angle_gb1_hss"] = ("time", theta - theta[0], {
        "units": "rad", "long_name": "GB1 HSS angle from record start (true, for reference)"})
    return ds


def _angle(y: np.ndarray, outputs: list[str], speed: str, dt: float) -> np.ndarray:
    """Shaft angle [rad] of a speed signal: the angle output where the bench has one
    (the HSS), else the trapezoidal integral of the speed from 0 (the LSS)."""
    angle = speed.replace("speed", "angle")
    if angle in outputs:
        return y[:, outputs.index(angle)]
    return cumulative_trapezoid(y[:, outputs.index(speed)], dx=dt, initial=0.0)


def _attrs(ds: xr.Dataset, cfg: Mapping[str, Any], **extra: Any) -> xr.Dataset:
    ds.attrs.update(
        gearbox_ratio=float(total_ratio(cfg["gearbox"]["stages"])),
        seed=int(cfg["seed"]),
        **extra,
    )
    return ds


def test(cfg: Mapping[str, Any], test: str, profile: str,
         measured_like: bool | None = None) -> xr.Dataset:
    """Simulate one closed-loop test variant.

    Parameters
    ----------
    cfg : mapping
        Validated configuration with ``campaign``, ``noise`` (and, for measured-like
        signals, ``excitation`` and ``tachometer``).
    test : str
        A ramp test (``speed_up``, ``speed_down``, ``torque_up``, ``torque_down``) or the
        name of a designed test of ``campaign.designed``.
    profile : {"square", "tapered"}
    measured_like : bool, optional
        Add harmonics, sensor noise and the tachometer; default ``campaign.measured_like``.

    Returns
    -------
    xarray.Dataset
        On ``time`` [s]: ``speed_ref`` [rad/s], ``torque_ref`` [N·m], the signals of
        :data:`SIGNALS` clean and, with ``_measured``, measured-like; ``pulse_time`` [s]
        on ``pulse``. With a ``drivetrain:``, that chain's record instead
        (:func:`gbpipe.simulate.chain_campaign.simulate_chain`: its sensors and motor
        torques, and the pulses of ``tachometer.sensor`` when one is named).

    Raises
    ------
    ValueError
        Unknown test or profile, bad durations, sample rate below 2.5× the highest
        excitation frequency — before any simulation.
    ExcitationError
        A designed test whose predicted motor torque (the clean simulation: references,
        designed signal and ripple) exceeds a motor's limit (``bench.torque_limit``, a
        drivetrain's ``torque_limit``) — before the measured-like signals are made.
    """
    if "campaign" not in cfg:
        raise ValueError("config has no 'campaign' section: add it (see config/README.md)")
    check_name(cfg, test, profile)
    camp = cfg["campaign"]
    if measured_like is None:
        measured_like = bool(camp["measured_like"])
    t, w_ref, t_ref = designed_reference(cfg, test, profile)
    if test in TESTS:
        key: tuple[int, ...] = (10 * TESTS.index(test) + PROFILES.index(profile),)
        check = None
    else:
        # by name, not list position: reordering campaign.designed changes no record
        key = (zlib.crc32(test.encode()), PROFILES.index(profile))

        def check(ss: NamedSS, ds: xr.Dataset) -> None:
            _check_torque_limit(cfg, test, profile, ss, ds)
    if cfg.get("drivetrain"):
        ds = simulate_chain(cfg, t, w_ref, t_ref, _rng(int(cfg["seed"]), *key), measured_like)
        if check is not None:
            check(bench_ss(cfg), ds)
        ds.attrs.update(seed=int(cfg["seed"]), test=test, profile=profile,
                        sample_rate=float(camp["sample_rate"]))
        return ds
    ds = _simulate(cfg, t, w_ref, t_ref, key, measured_like, check)
    return _attrs(ds, cfg, test=test, profile=profile,
                  sample_rate=float(camp["sample_rate"]))


def _check_torque_limit(cfg: Mapping[str, Any], name: str, profile: str, ss: NamedSS,
                        ds: xr.Dataset) -> None:
    """Refuse a designed test whose simulated motor torque exceeds the motor's limit.

    The bench is linear: the motor torque is the response to the designed signal alone
    (from rest) plus that to everything else, which :func:`within_limits` takes as the
    reference, so its message gives the factor on the signal's rms that would fit.
    """
    i, spec = designed_spec(cfg, name)
    _, x = designed_setpoint(cfg, name, profile)
    limits = _torque_limits(cfg)
    outs = [f"motor_torque_{m}" for m in limits]
    resp, _ = lsim(ss.select([f"{spec['setpoint']}_ref"], outs), x[:, None],
                   float(ds.time[1] - ds.time[0]))
    for j, (m, (limit, key)) in enumerate(limits.items()):
        total = ds[outs[j]].values
        try:
            within_limits(total - resp[:, j], resp[:, j], limit,
                          f"{outs[j]} (simulated)", float(cfg["campaign"]["sample_rate"]))
        except ExcitationError as exc:
            raise ExcitationError(
                f"campaign.designed[{i}] ({name}, {profile} profile) drives the {m} motor "
                f"beyond {key}: {exc}. Lower campaign.designed[{i}].rms, "
                f"or raise {key} if the motor allows it") from None


def _torque_limits(cfg: Mapping[str, Any]) -> dict[str, tuple[float, str]]:
    """Peak torque [N·m] and its key path, by motor: a drivetrain's motors that give
    ``torque_limit``, else the paper's ``bench.torque_limit``."""
    if cfg.get("drivetrain"):
        return {m.name: (float(m.torque_limit), f"drivetrain.motors[{m.index}].torque_limit")
                for m in bench_chain(cfg).motors if m.torque_limit is not None}
    return {m: (float(cfg["bench"]["torque_limit"][m]), f"bench.torque_limit.{m}")
            for m in MOTORS}


def sweep(cfg: Mapping[str, Any]) -> xr.Dataset:
    """Simulate the constant-torque speed sweep with measured-like signals and pulses.

    Returns
    -------
    xarray.Dataset
        As :func:`test`, plus ``rpm`` [rev/min] of the GB1 HSS vs time (clean).
    """
    if "sweep" not in cfg:
        raise ValueError("config has no 'sweep' section: add it (see config/README.md)")
    t, w_ref, t_ref = sweep_reference(cfg["sweep"])
    if "noise" in cfg["sweep"]:
        # the sweep may carry its own noise levels (a measured-like bench record, where
        # both motors ripple) over those of the identification campaign
        cfg = {**cfg, "noise": _overlay(cfg["noise"], cfg["sweep"]["noise"])}
    ds = _simulate(cfg, t, w_ref, t_ref, (99,), True)
    ds["rpm"] = ("time", ds.speed_gb1_hss.values / RPM,
                 {"units": "rev/min", "long_name": "GB1 HSS speed"})
    return _attrs(ds, cfg, test="sweep", sample_rate=float(cfg["sweep"]["sample_rate"]))


def random_only(cfg: Mapping[str, Any]) -> dict[str, Any]:
    """The configuration with every angle-locked excitation switched off, nothing else.

    Angle-locked: the gear and shaft excitation (``excitation``) and the converters'
    pulsating torque (``noise.motor_ripple.<motor>.pulsating``, also in ``sweep.noise``),
    the ``motor`` family of :func:`gbpipe.harmonics.excitation_families`.
    Simulating it (:func:`sweep`, :func:`test`) gives the *random-only* record of the
    exact separation metric (:mod:`gbpipe.harmonics.separation`): the broadband motor
    ripple and the sensor noise come from ``SeedSequence(seed, key)`` and are drawn
    before, and independently of, the excitation, whose phases have their own generators
    and are drawn for every configured order whatever its amplitude; a zero amplitude
    only zeroes that input, whose response is then exactly zero. So ``record -
    random_only`` is exactly the harmonic part.
    """
    exc = cfg["excitation"]
    quiet = {
        **exc,
        "shaft_orders": [{**s, "amplitude": 0.0} for s in exc["shaft_orders"]],
        "mesh": [{**m, "amplitude": 0.0} for m in exc["mesh"]],
    }
    out = {**cfg, "excitation": quiet, "noise": quiet_pulsating(cfg["noise"])}
    # a workflow job gets only the sections it reads (a test's slice has no sweep);
    # where present, the sweep's noise section is complete after validation
    if "sweep" in cfg:
        out["sweep"] = {**cfg["sweep"], "noise": quiet_pulsating(cfg["sweep"]["noise"])}
    return out


def quiet_pulsating(noise: Mapping[str, Any]) -> dict[str, Any]:
    """A ``noise`` section with every pulsating-torque amplitude 0 (nothing else)."""
    ripple = {m: {**spec, "pulsating": [{**line, "amplitude": 0.0}
                                        for line in spec["pulsating"]]}
              for m, spec in noise["motor_ripple"].items()}
    return {**noise, "motor_ripple": ripple}
