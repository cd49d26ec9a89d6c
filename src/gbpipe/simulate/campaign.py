"""Closed-loop test campaigns and the speed sweep, clean and measured-like.

Each record is simulated with the closed-loop bench of :func:`gbpipe.model.bench_ss`
from its steady state at the first reference values:

* **clean**: references plus motor torque ripple (process noise);
* **measured-like**: clean plus the bench's response to excitation locked to shaft angle
  (shaft orders as an angle error across each HSS coupling, gear-mesh transmission errors
  with harmonics on the shaft after each stage, amplitudes proportional to the torque
  reference) plus sensor noise, and the GB1 HSS tachometer pulse train.

The excitation phase follows the *clean* HSS angles: the angle perturbation caused by the
excitation itself is micro-radians, so the superposition is exact to that order and the
bench dynamics (the ~62 Hz resonance) shape every harmonic as in a real bench.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr
from scipy.linalg import null_space

from gbpipe.kinematics import order_of, total_ratio
from gbpipe.lti import NamedSS, lsim
from gbpipe.model import bench_ss
from gbpipe.simulate.profiles import (
    PROFILES,
    RPM,
    TESTS,
    check_test,
    step_reference,
    sweep_reference,
)
from gbpipe.simulate.signals import SIGNALS
from gbpipe.simulate.tacho import pulse_times, tooth_errors

__all__ = ["test", "sweep", "steady_state", "SIGNALS"]

_ANGLES = ("angle_gb1_hss", "angle_gb2_hss")
#: Seconds of excitation simulated before each record (discarded): > 5 time constants of
#: the lightly damped bench modes the harmonics excite.
PREROLL = 2.0


def steady_state(ss: NamedSS, u0: np.ndarray, omega0: float) -> np.ndarray:
    """Closed-loop state in steady rotation at ``omega0`` [rad/s] under inputs ``u0``.

    Every derivative but the angles' is zero, every body turns at its kinematic share of
    ``omega0`` (the rigid-body mode of the stiffness matrix), and the GB1 HSS angle is 0.
    """
    n_q = sum(s.startswith("angle[") for s in ss.states)
    n = ss.A.shape[0]
    K = -ss.A[n_q:2 * n_q, :n_q]          # M⁻¹K: same null space as K
    rigid = null_space(K)
    if rigid.shape[1] != 1:
        raise RuntimeError(f"expected one rigid-body mode, found {rigid.shape[1]}")
    r = rigid[:, 0] / rigid[ss.states.index("angle[driver_motor]"), 0]
    select_speeds = np.hstack([np.zeros((n_q, n_q)), np.eye(n_q), np.zeros((n_q, n - 2 * n_q))])
    rows = [ss.A[n_q:], select_speeds, ss.C[[ss.outputs.index("angle_gb1_hss")]]]
    rhs = [-ss.B[n_q:] @ u0, omega0 * r, np.zeros(1)]
    E, b = np.vstack(rows), np.concatenate(rhs)
    x0, *_ = np.linalg.lstsq(E, b, rcond=None)
    resid = np.abs(E @ x0 - b).max()
    if resid > 1e-6 * max(1.0, np.abs(b).max()):
        raise RuntimeError(f"no steady state found (residual {resid:.3g})")
    return x0


def _overlay(base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    """Nested copy of `base` with the values of `over` replacing its own, key by key."""
    out = dict(base)
    for k, v in over.items():
        both = isinstance(v, Mapping) and isinstance(base.get(k), Mapping)
        out[k] = _overlay(base[k], v) if both else v
    return out


def _rng(seed: int, *key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=key))


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
        for s, ph in zip(exc["shaft_orders"], ph_shaft, strict=True):
            out[:, col] += float(s["amplitude"]) * np.sin(float(s["order"]) * theta + ph)
        for m, phs in zip(exc["mesh"], ph_mesh, strict=True):
            col = names.index(f"te_{g}_mesh{m['stage']}")
            o = float(order_of(stages, f"mesh{m['stage']}"))
            for h, (w, ph) in enumerate(zip(m["harmonics"], phs, strict=True), start=1):
                out[:, col] += float(m["amplitude"]) * w * np.sin(h * o * theta + ph)
    return out * scale[:, None]


def _simulate(cfg: Mapping[str, Any], t: np.ndarray, speed_ref: np.ndarray,
              torque_ref: np.ndarray, noise_key: int, measured: bool) -> xr.Dataset:
    ss = bench_ss(cfg)
    n = t.size
    dt = float(t[1] - t[0])
    noise = cfg["noise"]
    rng = _rng(int(cfg["seed"]), noise_key)
    ripple = np.column_stack([
        rng.standard_normal(n) * float(noise["motor_ripple"]["driver"]),
        rng.standard_normal(n) * float(noise["motor_ripple"]["driven"]),
    ])
    outputs = list(SIGNALS) + list(_ANGLES)
    main = ss.select(["speed_ref", "torque_ref", "disturbance_driver", "disturbance_driven"],
                     outputs)
    u = np.column_stack([speed_ref, torque_ref, ripple])
    x0 = steady_state(main, np.array([speed_ref[0], torque_ref[0], 0.0, 0.0]), speed_ref[0])
    y, _ = lsim(main, u, dt, x0)
    ds = xr.Dataset(coords={"time": ("time", t, {"units": "s", "long_name": "time from record "
                                                 "start", "axis": "T"})})
    ds["speed_ref"] = ("time", speed_ref, {"units": "rad/s", "long_name": "HSS speed reference"})
    ds["torque_ref"] = ("time", torque_ref, {"units": "N m",
                                             "long_name": "braking torque reference at HSS"})
    for i, (name, (unit, long_name, _)) in enumerate(SIGNALS.items()):
        ds[name] = ("time", y[:, i], {"units": unit, "long_name": f"{long_name}, clean"})
    if not measured:
        return ds
    exc_names = [s for s in ss.inputs if s.startswith(("te_", "misalign_"))]
    # The excitation runs for PREROLL seconds before the record starts (angles extended
    # back at the initial speed), so the record holds its steady response, not the
    # transient of switching it on at t = 0.
    n_pre = int(round(PREROLL / dt))
    t_pre = (np.arange(-n_pre, 0)) * dt
    angles = {}
    for a in _ANGLES:
        th = y[:, outputs.index(a)]
        w0 = y[0, outputs.index(a.replace("angle", "speed"))]
        angles[a] = np.concatenate([th[0] + w0 * t_pre, th])
    load = np.concatenate([np.full(n_pre, torque_ref[0]), torque_ref])
    e = _excitation(cfg, exc_names, angles, load)
    ye, _ = lsim(ss.select(exc_names, outputs), e, dt)
    ye = ye[n_pre:]
    sensor = noise["sensor"]
    for i, (name, (unit, long_name, kind)) in enumerate(SIGNALS.items()):
        std = float(sensor[kind])
        ds[f"{name}_measured"] = ("time", y[:, i] + ye[:, i] + std * rng.standard_normal(n), {
            "units": unit, "long_name": f"{long_name}, measured-like (harmonics + sensor noise)"})
    tach = cfg["tachometer"]
    theta = y[:, outputs.index("angle_gb1_hss")] + ye[:, outputs.index("angle_gb1_hss")]
    omega = y[:, outputs.index("speed_gb1_hss")] + ye[:, outputs.index("speed_gb1_hss")]
    ppr = int(tach["pulses_per_rev"])
    spacing = tooth_errors(ppr, float(tach["spacing_error"]),
                           _rng(int(cfg["excitation"]["seed"]), 2))
    pulses = pulse_times(t, theta - theta[0], ppr, speed=omega, spacing_error_rad=spacing,
                         clock_hz=float(tach["clock_hz"]))
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
    test : {"speed_up", "speed_down", "torque_up", "torque_down"}
    profile : {"square", "tapered"}
    measured_like : bool, optional
        Add harmonics, sensor noise and the tachometer; default ``campaign.measured_like``.

    Returns
    -------
    xarray.Dataset
        On ``time`` [s]: ``speed_ref`` [rad/s], ``torque_ref`` [N·m], the signals of
        :data:`SIGNALS` clean and, with ``_measured``, measured-like; ``pulse_time`` [s]
        on ``pulse``.

    Raises
    ------
    ValueError
        Unknown test or profile, bad durations, sample rate below 2.5× the highest
        excitation frequency — before any simulation.
    """
    check_test(test, profile)
    if "campaign" not in cfg:
        raise ValueError("config has no 'campaign' section: add it (see config/README.md)")
    camp = cfg["campaign"]
    if measured_like is None:
        measured_like = bool(camp["measured_like"])
    t, w_ref, t_ref = step_reference(camp, test, profile)
    key = 10 * TESTS.index(test) + PROFILES.index(profile)
    ds = _simulate(cfg, t, w_ref, t_ref, key, measured_like)
    return _attrs(ds, cfg, test=test, profile=profile,
                  sample_rate=float(camp["sample_rate"]))


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
    ds = _simulate(cfg, t, w_ref, t_ref, 99, True)
    ds["rpm"] = ("time", ds.speed_gb1_hss.values / RPM,
                 {"units": "rev/min", "long_name": "GB1 HSS speed"})
    return _attrs(ds, cfg, test="sweep", sample_rate=float(cfg["sweep"]["sample_rate"]))


def random_only(cfg: Mapping[str, Any]) -> dict[str, Any]:
    """The configuration with every angle-locked excitation switched off, nothing else.

    Simulating it (:func:`sweep`, :func:`test`) gives the *random-only* record of the
    exact separation metric (:mod:`gbpipe.harmonics.separation`): the motor ripple and
    sensor noise come from ``SeedSequence(seed, key)`` and are drawn before, and
    independently of, the excitation, whose phases have their own generator
    (``excitation.seed``) and are drawn for every configured order whatever its
    amplitude; a zero amplitude only zeroes the excitation input, whose response is then
    exactly zero. So ``record - random_only`` is exactly the harmonic part.
    """
    exc = cfg["excitation"]
    quiet = {
        **exc,
        "shaft_orders": [{**s, "amplitude": 0.0} for s in exc["shaft_orders"]],
        "mesh": [{**m, "amplitude": 0.0} for m in exc["mesh"]],
    }
    return {**cfg, "excitation": quiet}

