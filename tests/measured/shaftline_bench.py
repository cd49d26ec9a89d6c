"""Bench files of a drivetrain described in config: a chain simulated as a bench logs it.

Given a config's ``drivetrain:`` description (docs/drivetrain.md), the chain is built
with the project's one mechanics core (:func:`gbpipe.model.assembly.bench_ss`: the
plant of :func:`gbpipe.model.chain.build_chain` with every motor's loop closed by
:func:`gbpipe.model.statespace.close_loops`) and simulated exactly (zero-order hold,
:func:`gbpipe.lti.lsim`). Excitation: a band-limited random torque added to the command of
the excited motors (``disturbance_<motor>``, seeded, independent; default the first
motor only, so that its measured torque is the one input of the record and the other
motors' loops are part of the path, as the truth model of a one-motor pairing holds
them), the references held at the operating point. Written: a CSV with the motor
torques (time column) and a TDMS file with the sensors and a 0-5 V tacho on one disk
(``wf_increment`` time base), each signal with seeded white sensor noise; plus the
``measured:`` mapping that reads them.

The operating point (a constant speed of the drive motor, a constant load torque) is
added as static offsets: the deviations are what the linear model predicts, and the
offsets follow from the gear ratios (lossless statics), so the record is consistent.

Run as a script to write the example's files: ``python tests/measured/shaftline_bench.py
shaftline/`` (the chain of ``config/examples/shaftline.yaml``, seed 1).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from nptdms import ChannelObject, TdmsWriter
from scipy import linalg, signal

from gbpipe.config.loader import load, read_yaml
from gbpipe.errors import UnstableGain
from gbpipe.fit.frf_data import FrfData, sigma_from_bounds
from gbpipe.fit.keypath import get_value, with_values
from gbpipe.identify import nonparametric_reference
from gbpipe.lti import lsim
from gbpipe.model.assembly import bench_chain, bench_ss
from gbpipe.model.frf import Pairing
from gbpipe.model.stability import check_stability
from tests.measured.bench_campaign import EPOCH, tacho_voltage

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "config" / "examples" / "shaftline.yaml"
#: Operating point: drive-motor speed [rad/s] (1000 rpm) and the load motor's torque [N·m].
SPEED, LOAD_TORQUE = 104.7, 150.0
#: Random motor-torque excitation: rms as a share of the load torque [-], band [Hz].
EXCITATION_SHARE, EXCITATION_BAND = 0.2, 400.0
#: Sensor noise: rms as a share of each signal's dynamic rms [-].
NOISE_SHARE = 0.02
#: Simulation rate of :func:`record_data` over the record's. The images of the excitation
#: held at the simulation rate still bias output/torque ratios, as 1/oversample: at the
#: shaft line's 33 Hz mode 7 % at 1, 1.2 % at 8, 0.6 % at 16 (0.2 % or less elsewhere),
#: against a scatter of 1–13 % there (exact discrete loop against the chain's FRF).
OVERSAMPLE = 16


class ShaftlineTruth(NamedTuple):
    """What the files encode.

    Attributes
    ----------
    cfg : dict
        ``{"drivetrain": ...}`` the record was simulated from (perturbations applied).
    spec : dict
        The ``measured:`` entry (paths relative to the folder).
    signals : dict of str -> ndarray
        Signal name -> values written [SI] (the noise included).
    """

    cfg: dict
    spec: dict
    signals: dict


def example_drivetrain() -> dict[str, Any]:
    """``{"drivetrain": ...}`` of config/examples/shaftline.yaml."""
    return {"drivetrain": read_yaml(EXAMPLE)["drivetrain"]}


def static_speeds(cfg: dict, speed: float) -> dict[str, float]:
    """Every disk's speed [rad/s] when the chain turns rigidly (no spring twisted, the
    ground held) with its first disk at ``speed``: the null space of the twist maps (a
    damper to ground, a mount of stiffness 0, holds no angle)."""
    mech = bench_chain(cfg).mechanism
    maps = mech.twist_maps()
    q = linalg.null_space(np.vstack([maps[s.name] for s in mech.springs
                                     if s.stiffness > 0]))[:, 0]
    full = mech.T @ q
    return {b.name: speed * v / full[0] for b, v in zip(mech.bodies, full, strict=True)}


def simulate(cfg: dict, fs: float, duration: float, seed: int, tacho_disk: str,
             excited: tuple[str, ...], references: bool = False,
             oversample: int = 1) -> dict[str, np.ndarray]:
    """The chain's logged signals [SI] on a uniform grid at ``fs`` [Hz] for ``duration`` [s],
    the motors named in ``excited`` driven by random torques (with ``references``, each
    also as ``disturbance_<motor>`` [N·m]: the noise-free reference of a closed-loop
    estimate). With ``oversample`` > 1 the chain runs (excitation held) at
    ``oversample·fs`` and every signal passes a data-acquisition anti-alias filter
    (:func:`scipy.signal.decimate`, zero-phase FIR) down to ``fs``: sampled at ``fs``
    directly, the held excitation's images fold into the motor torque, whose notch at a
    mode then makes output/torque ratios differ from the chain's FRF (up to 7 % at the
    shaft line's 33 Hz mode at 2 kHz; the difference falls as ``1/oversample``)."""
    # a closed loop that grows is no bench record (its Welch estimate has no stationary
    # expectation): refused, naming the gain
    check_stability(cfg)
    rng = np.random.default_rng(seed)
    ss = bench_ss(cfg)
    n = int(round(duration * fs))
    t = np.arange(n) / fs
    fast = n * oversample
    b, a = signal.butter(4, EXCITATION_BAND, fs=fs * oversample)
    u = np.zeros((fast, len(ss.inputs)))
    for i, name in enumerate(ss.inputs):
        if name.removeprefix("disturbance_") in excited:
            u[:, i] = signal.lfilter(b, a, rng.standard_normal(fast))
            u[:, i] *= EXCITATION_SHARE * LOAD_TORQUE / u[:, i].std()
    y, _ = lsim(ss, u, 1.0 / (fs * oversample))
    if oversample > 1:
        y = signal.decimate(y, oversample, ftype="fir", axis=0)
        u = signal.decimate(u, oversample, ftype="fir", axis=0)
    out_r = {name: u[:, i] for i, name in enumerate(ss.inputs)
             if references and name.removeprefix("disturbance_") in excited}
    speeds = static_speeds(cfg, SPEED)
    desc = cfg["drivetrain"]
    out: dict[str, np.ndarray] = {"time": t, **out_r}
    for j, name in enumerate(ss.outputs):
        dyn = y[:, j] + NOISE_SHARE * y[:, j].std() * rng.standard_normal(n)
        out[name] = dyn + static_offset(desc, name, speeds)
    node = tacho_disk
    out["tacho"] = tacho_voltage(t, speeds[node] + y[:, ss.outputs.index(speed_sensor(
        desc, node))], 1)
    return out


def record_data(cfg: dict, truth: dict, seed: int, duration: float,
                fs: float = 2000.0, reference: bool = True,
                oversample: int = OVERSAMPLE) -> list[FrfData]:
    """The pairings' nonparametric FRFs of one record of ``truth``, as the fit takes them.

    The record: :func:`simulate` of ``truth`` [``duration`` s at ``fs`` Hz, the first
    motor excited, run at ``oversample·fs`` behind an anti-alias filter]; per pairing of
    ``cfg["identify"]``: the closed-loop estimate through the excitation (``S_yr S_ur⁻¹``,
    :func:`gbpipe.identify.nonparametric_reference`; the record carries its reference)
    where coherent, inside ``cfg["fit"]["band"]`` [Hz], sigma from its 95 % bounds, the
    zero-order hold's own response divided out, the Welch segment and the excited motor
    named (``FrfData.segment``, ``FrfData.excitation``: the fit compares with the model
    seen through the window, weighted by the input's spectrum the motor's loop shapes).
    ``reference=False``: H1 instead, biased by the noise of the measured motor torque.
    """
    motor = truth["drivetrain"]["motors"][0]["name"]
    sig = simulate(truth, fs, duration, seed, "load", (motor,), reference, oversample)
    s = cfg["identify"]
    band = cfg["fit"]["band"]
    out = []
    for p in s["pairings"]:
        pairing = Pairing.from_config(p)
        u = np.column_stack([sig[n] - sig[n].mean() for n in pairing.inputs])
        y = np.column_stack([sig[n] - sig[n].mean() for n in pairing.outputs])
        r = sig[f"disturbance_{motor}"][:, None] if reference else None
        ref = nonparametric_reference(u, y, fs, s, r)
        keep = ref.assessable & (ref.frequency >= band[0]) & (ref.frequency <= band[1])
        f = ref.frequency[keep]
        # the simulation holds its inputs over a sample (ZOH) of the fast rate fs·oversample:
        # the sampled response is the model's times exp(-jπf/fs)·sinc(f/fs) at that rate
        # (the hold's own response), removed here
        hold = np.exp(-1j * np.pi * f / (fs * oversample)) * np.sinc(f / (fs * oversample))
        g = ref.frf[keep] / hold[:, None, None]
        out.append(FrfData(pairing, f, g, sigma_from_bounds(ref.lower[keep], ref.upper[keep]),
                           s["nonparametric"]["segment"], motor,
                           "reference" if reference else "h1"))
    return out


def perturbed(cfg: dict, free: list[str], rng: np.random.Generator) -> tuple[dict, np.ndarray]:
    """``cfg`` with each ``free`` number scaled by a random sign and size 15–40 %, drawn
    again while the perturbed chain's closed loop is unstable (the shaft line's load-side
    27 Hz mode is 0.05 % damped in closed loop; a few draws push it past zero, a bench
    nobody runs). Returns the perturbed config and the factors."""
    while True:
        factors = 1 + rng.choice([-1, 1], len(free)) * rng.uniform(0.15, 0.40, len(free))
        truth = with_values(cfg, {p: get_value(cfg, p) * x for p, x in
                                  zip(free, factors, strict=True)})
        try:
            check_stability(truth)
        except UnstableGain:
            continue
        return truth, factors


def speed_sensor(desc: dict, node: str) -> str:
    return next(s["name"] for s in desc["sensors"] if s.get("speed") == node)


def static_offset(desc: dict, name: str, speeds: dict[str, float]) -> float:
    # static value of a signal at the operating point (lossless: torque x speed constant)
    sensor = next((s for s in desc["sensors"] if s["name"] == name), None)
    # the motor that holds the load: the torque-controlled one, else (motors without
    # a modelled loop, a bench record's description) the last
    load = next((m for m in desc["motors"] if m.get("controller", {}).get("type") == "torque"),
                desc["motors"][-1])
    power = LOAD_TORQUE * abs(speeds[load["node"]])
    if sensor is None:  # motor_torque_<motor>
        motor = next(m for m in desc["motors"] if name == f"motor_torque_{m['name']}")
        return power / abs(speeds[motor["node"]])
    if "speed" in sensor:
        return speeds[sensor["speed"]]
    if "torque" in sensor:
        spring = next(s for s in desc["shafts"] + desc.get("mounts", [])
                      if s["name"] == sensor["torque"])
        if "between" not in spring:
            return 0.0
        return sensor.get("sign", 1) * power / abs(speeds[spring["between"][0]])
    return 0.0


def write_bench(folder: Path, cfg: dict | None = None, *, fs: float = 2000.0,
                duration: float = 30.0, seed: int = 1, perturb: dict | None = None,
                tacho_disk: str = "load", name: str = "run1",
                excited: tuple[str, ...] | None = None) -> ShaftlineTruth:
    """Write a record of a drivetrain as bench files in ``folder``; return the truth.

    Parameters
    ----------
    folder : Path
        Where ``<name>_motors.csv`` and ``<name>.tdms`` go (created).
    cfg : dict, optional
        Holds ``drivetrain:`` (default the example's chain).
    fs, duration : float
        Logging rate [Hz] and record length [s].
    seed : int
        Seed of the excitation and the sensor noise.
    perturb : dict, optional
        Key path -> factor applied to the description before simulating
        (``{"drivetrain.disks.flywheel.inertia": 1.3}``).
    tacho_disk : str
        The disk whose speed sensor drives the tacho.
    name : str
        Record name (file stem).
    excited : tuple of str, optional
        Motors driven by a random torque (default the first motor of the description).
    """
    cfg = example_drivetrain() if cfg is None else {"drivetrain": cfg["drivetrain"]}
    if perturb:
        cfg = with_values(cfg, {p: f * get_value(cfg, p) for p, f in perturb.items()})
    folder.mkdir(parents=True, exist_ok=True)
    if excited is None:
        excited = (cfg["drivetrain"]["motors"][0]["name"],)
    sig = simulate(cfg, fs, duration, seed, tacho_disk, excited, references=True,
                   oversample=OVERSAMPLE)
    # the excitation generator's output, logged as a bench logs it (the set-point of a
    # closed-loop estimate: identify.pairings[].reference)
    sig = {k.replace("disturbance_", "excitation_"): v for k, v in sig.items()}
    motors = [k for k in sig if k.startswith("motor_torque_")]
    sensors = [k for k in sig if k not in motors and k != "time"]
    pd.DataFrame({"time": sig["time"], **{m: sig[m] for m in motors}}).to_csv(
        folder / f"{name}_motors.csv", index=False, float_format="%.12g")
    props = {"wf_increment": 1.0 / fs, "wf_start_offset": 0.0, "wf_start_time": EPOCH}
    units = {"tacho": "V"}
    with TdmsWriter(folder / f"{name}.tdms") as w:
        w.write_segment([ChannelObject("Sensors", s, sig[s], properties={
            **props, "unit_string": units.get(s, _unit(s))}) for s in sensors])
    spec = {"files": {"motors": {"path": f"{name}_motors.csv", "time": "time"},
                      "daq": {"path": f"{name}.tdms"}},
            "sample_rate": fs,
            "signals": {**{m: {"file": "motors", "channel": m, "unit": "N*m"} for m in motors},
                        **{s: {"file": "daq", "channel": f"Sensors/{s}"} for s in sensors
                           if s != "tacho"},
                        "tacho": {"file": "daq", "channel": "Sensors/tacho",
                                  "quantity": "tacho", "pulses_per_rev": 1}},
            "gaps": "refuse", "orders": []}
    return ShaftlineTruth(cfg, spec, sig)


def _unit(signal_name: str) -> str:
    return "rad/s" if signal_name.startswith("speed") else "N*m"


def main(argv: list[str]) -> None:
    """``folder [--config overlay.yaml] [--name N] [--tacho DISK] [--perturb PATH=F ...]``:
    the records of the overlay's chain (on config/config.yaml; default the shaft-line
    example's), as the example's tests write them."""
    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("folder", nargs="?", default="shaftline")
    ap.add_argument("--config", help="overlay with the drivetrain (its records' chain)")
    ap.add_argument("--name", default="run1")
    ap.add_argument("--tacho", default="load", help="disk whose speed drives the tacho")
    ap.add_argument("--perturb", nargs="*", default=[], metavar="PATH=FACTOR")
    ap.add_argument("--duration", type=float, default=30.0)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    cfg = load(ROOT / "config" / "config.yaml", args.config) if args.config else None
    perturb = {p: float(f) for p, f in (item.split("=") for item in args.perturb)}
    write_bench(Path(args.folder), cfg, perturb=perturb, name=args.name,
                tacho_disk=args.tacho, duration=args.duration, seed=args.seed)
    print(f"bench files written to {args.folder}/")


if __name__ == "__main__":
    main(sys.argv[1:])
