"""Cross-field checks of the simulated records: test campaign and speed sweep.

Known from the configuration before anything is simulated: the steps stay inside the
bench's range, the sample rate resolves the configured excitation, the sweep is not
faster than the bench can ramp, and no record is too large to hold in memory. None of it
applies to bench records (:func:`gbpipe.config.scope.simulated` false): nothing is
simulated there.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from gbpipe.config.scope import simulated
from gbpipe.errors import ConfigError
from gbpipe.kinematics import order_of
from gbpipe.model.chain import build_chain
from gbpipe.simulate.chain_campaign import chain_loops, chain_ripple
from gbpipe.simulate.noise import MOTORS
from gbpipe.simulate.profiles import ramp_rate, test_duration

__all__ = ["MAX_SAMPLES", "highest_excitation_hz", "check_campaign", "check_sweep"]

#: Largest record [samples]: a record holds ~20 signals of 8 bytes per sample, so 1e7
#: samples is ~1.6 GB, the memory the simulation rules reserve.
MAX_SAMPLES = 10_000_000


def highest_excitation_hz(cfg: Mapping[str, Any], rpm_max: float) -> float:
    """Highest frequency [Hz] of the configured shaft and mesh excitation at ``rpm_max``."""
    exc = cfg["excitation"]
    orders = [float(s["order"]) for s in exc["shaft_orders"] if s["amplitude"] > 0]
    for m in exc["mesh"]:
        o = float(order_of(cfg["gearbox"]["stages"], f"mesh{m['stage']}"))
        orders.append(o * len(m["harmonics"]))
    return rpm_max / 60.0 * max(orders, default=0.0)


def _check_rate(cfg: Mapping[str, Any], field: str, fs: float, rpm_max: float) -> None:
    # 2.5 x: the excitation must sit below the Nyquist frequency with room for the
    # anti-aliasing transition of any later decimation
    f_max = highest_excitation_hz(cfg, rpm_max)
    if fs < 2.5 * f_max:
        raise ConfigError(field, f"{fs:g} Hz is below 2.5 × the highest excitation frequency "
                          f"({f_max:.1f} Hz at {rpm_max:g} rpm); raise it to at least "
                          f"{2.5 * f_max:.0f} Hz or drop high mesh harmonics")


def _check_size(field: str, duration: float, fs: float) -> None:
    n = duration * fs
    if n > MAX_SAMPLES:
        raise ConfigError(field, f"{fs:g} Hz over a {duration:g} s record gives {n:.3g} "
                          f"samples, more than {MAX_SAMPLES:.0e} (memory); lower the rate or "
                          "shorten the record")


def _check_model_grid(cfg: Mapping[str, Any]) -> None:
    fr = cfg["model"]["frf"]
    if fr["f_min"] >= fr["f_max"]:
        raise ConfigError("model.frf.f_min", f"{fr['f_min']:g} Hz must be below "
                          f"model.frf.f_max ({fr['f_max']:g} Hz)")


def _check_clock(cfg: Mapping[str, Any], rpm_max: float) -> None:
    # pulse times are floored to clock ticks: two pulses in one tick would make the pulse
    # train non-increasing, which the tachometer processing refuses
    tach = cfg["tachometer"]
    rate = tach["pulses_per_rev"] * rpm_max / 60.0
    if tach["clock_hz"] < 2 * rate:
        raise ConfigError("tachometer.clock_hz", f"{tach['clock_hz']:g} Hz cannot time "
                          f"{rate:.1f} pulses/s ({tach['pulses_per_rev']} per revolution at "
                          f"{rpm_max:g} rpm); use at least {2 * rate:.0f} Hz")
    # jitter must not reorder pulses nor trip the tachometer checks (25 % of an interval):
    # 5 sigma below a tenth of the shortest interval
    if 50 * tach["jitter"] * rate > 1:
        raise ConfigError("tachometer.jitter", f"{tach['jitter']:g} s rms is not far below "
                          f"the shortest pulse interval {1 / rate:.3g} s (at {rpm_max:g} rpm); "
                          f"use at most {1 / (50 * rate):.3g} s")


def _check_paper_ripple(noise: Mapping[str, Any], where: str) -> None:
    # the schema takes any motor name; the paper bench has two, and a drivetrain's motor
    # carries its ripple in its own entry (never read here by name: config.yaml's
    # driver/driven would stand for a chain motor of that name)
    for key in noise.get("motor_ripple", {}):
        if key not in MOTORS:
            raise ConfigError(f"{where}.motor_ripple.{key}", "names no motor of the paper's "
                              f"bench; use {' or '.join(MOTORS)} (a drivetrain motor's "
                              "ripple is its own entry's: drivetrain.motors[i].ripple, "
                              "N·m rms)")


def _check_chain_campaign(cfg: Mapping[str, Any], rpm_max: float) -> None:
    # a chain's campaign: one speed and one torque loop, a ripple per motor; no
    # angle-locked excitation to resolve; a tachometer only on a named angle sensor
    # (gbpipe.simulate.chain_campaign)
    chain = build_chain(cfg["drivetrain"])
    chain_loops(chain)
    chain_ripple(cfg, chain)
    sensor = cfg["tachometer"].get("sensor")
    if sensor and sensor not in chain.angle_sensors:
        raise ConfigError("tachometer.sensor", f"'{sensor}' is not an angle sensor of the "
                          f"drivetrain; use one of {sorted(chain.angle_sensors)} or add "
                          "'{name: ..., angle: <disk>}' to drivetrain.sensors")
    if sensor:
        _check_clock(cfg, rpm_max)
    other = [v for v in cfg["identify"]["versions"] if v not in ("clean", "raw")]
    if other:
        raise ConfigError("identify.versions", f"{other}: TSA and harmonic removal are "
                          "the paper gearbox's (its orders and tachometer); a simulated "
                          "drivetrain's campaign identifies 'clean' and 'raw'")


def check_campaign(cfg: Mapping[str, Any]) -> None:
    """Check steps, ranges, sample rate and record sizes of the ``campaign`` section.

    Only when the campaign is simulated (:func:`~gbpipe.config.scope.simulated`).
    """
    if not simulated(cfg):
        return
    _check_paper_ripple(cfg["noise"], "noise")
    camp = cfg["campaign"]
    nom, st, fr = camp["nominal"], camp["step"], camp["full_range"]
    if st["speed_rpm"] >= nom["speed_rpm"]:
        raise ConfigError("campaign.step.speed_rpm", f"{st['speed_rpm']:g} rpm: a step down "
                          f"would stop the bench; keep it below campaign.nominal.speed_rpm "
                          f"({nom['speed_rpm']:g} rpm)")
    for key in ("speed_rpm", "torque"):
        if nom[key] + st[key] > fr[key]:
            raise ConfigError(f"campaign.step.{key}",
                              f"nominal + step = {nom[key] + st[key]:g} exceeds the bench's "
                              f"full range campaign.full_range.{key} = {fr[key]:g}")
    fs = float(camp["sample_rate"])
    if cfg.get("drivetrain"):
        _check_chain_campaign(cfg, nom["speed_rpm"] + st["speed_rpm"])
    else:
        if cfg["tachometer"].get("sensor"):
            raise ConfigError("tachometer.sensor", "names a drivetrain's angle sensor; the "
                              "paper bench's tachometer is on the GB1 HSS: remove the key")
        _check_rate(cfg, "campaign.sample_rate", fs, nom["speed_rpm"] + st["speed_rpm"])
        _check_clock(cfg, nom["speed_rpm"] + st["speed_rpm"])
    _check_model_grid(cfg)
    longest = max(test_duration(camp, t, p) for t in camp["tests"] for p in camp["profiles"])
    _check_size("campaign.sample_rate", longest, fs)


def check_sweep(cfg: Mapping[str, Any]) -> None:
    """Check the ``sweep`` section: speeds, ramp rate, sample rate, record size.

    Not with a ``drivetrain:`` (the sweep is the paper bench's: its rule is skipped) nor
    with bench records (nothing is simulated).
    """
    if cfg.get("drivetrain") or not simulated(cfg):
        return
    _check_paper_ripple(cfg["sweep"].get("noise", {}), "sweep.noise")
    sw = cfg["sweep"]
    if sw["rpm_end"] == sw["rpm_start"]:
        raise ConfigError("sweep.rpm_end", f"{sw['rpm_end']:g} rpm equals sweep.rpm_start: a "
                          "sweep needs a different end speed")
    fr = cfg["campaign"]["full_range"]
    for key, value, limit in (("rpm_start", sw["rpm_start"], fr["speed_rpm"]),
                              ("rpm_end", sw["rpm_end"], fr["speed_rpm"]),
                              ("torque", sw["torque"], fr["torque"])):
        if value > limit:
            raise ConfigError(f"sweep.{key}", f"{value:g} exceeds the bench's full range "
                              f"campaign.full_range.{'torque' if key == 'torque' else 'speed_rpm'}"
                              f" = {limit:g}")
    fs = float(sw["sample_rate"])
    _check_rate(cfg, "sweep.sample_rate", fs, max(sw["rpm_start"], sw["rpm_end"]))
    _check_clock(cfg, max(sw["rpm_start"], sw["rpm_end"]))
    rate = ramp_rate(cfg["campaign"], "speed")
    needed = abs(sw["rpm_end"] - sw["rpm_start"]) / rate
    if sw["duration"] < needed:
        raise ConfigError("sweep.duration", f"{sw['duration']:g} s is faster than the bench's "
                          f"ramp rate ({rate:.1f} rpm/s); use at least {needed:.1f} s")
    _check_size("sweep.sample_rate", sw["settle"] + sw["duration"], fs)
