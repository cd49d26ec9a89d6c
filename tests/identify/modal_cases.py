"""Random geared torsional chains as bench files: the cases of the modal-selection benchmark.

Every number is drawn from ``numpy.random.default_rng(seed)``; nothing is tuned to gbpipe.
A case is an openTorsion assembly (an independent library: its own element matrices and
gear-constraint reduction) simulated with scipy and written as a CSV bench file with the
``measured:`` mapping that reads it (:func:`gbpipe.measured.read`).

The chain (:func:`draw_chain`)
    4-12 disks on 2-4 shaft lines joined by 1-3 rigid gear stages (openTorsion ``Gear``:
    a pinion closing one line, a wheel opening the next, radius ratio 0.3-4); massless
    shafts of stiffness 10^4-10^6 N·m/rad; inertias 10^-2-10^0.5 kg·m² (gears
    10^-2.5-10^-0.5); the motor disk (node 0) held to ground by a spring, the stiffness
    of a speed loop (no rigid-body mode), 10^-2-10^0 of the softest shaft. Every
    stiffness is then scaled by one factor drawn so that all modes lie in 5-400 Hz
    (frequencies scale with its square root); a draw whose modes span more than 80:1, or
    with two modes closer than ``min_gap_hz`` (a pair no spectrum of the record's
    resolution separates), is rejected and redrawn. Modal damping: a damping ratio per
    mode, log-uniform 0.5-10 %, as openTorsion's ``C_modal`` damping matrix.

The record (:func:`simulate`)
    Exact zero-order-hold discretisation (:func:`scipy.signal.cont2discrete`) at
    ``fs`` (default 2 kHz, twice the identify stage's 1 kHz: its anti-aliasing filter
    then passes 400 Hz, every mode), simulated with :func:`scipy.signal.dlsim`.
    Inputs: the motor torque on node 0, a seeded white noise band-passed to a random
    ``f_lo``-``f_hi`` (5-60 Hz, 150-350 Hz; 4th-order Butterworth) and, in half the
    cases, notched (a 4th-order band stop 10-40 Hz wide): outside that band the record
    is incoherent, so some modes cannot be asked of it; and an unmeasured angle-locked
    torque on a node of the tacho shaft's line, ``sum_k a_k sin(k theta + phi_k)`` over
    3-8 distinct integer orders ``k`` of the shaft (``k f_shaft <= 350 Hz``), each
    ``a_k`` 10^-1-10^0 of the motor torque's rms (a line 0-25 dB above the broadband
    level of a 0.5 Hz bin). The shaft turns at ``f_shaft`` 5-30 Hz, rising linearly by
    0-2 % over the record. Outputs: a torque meter (the elastic torque of a random shaft)
    and the speed of a random node of the last line; each measured signal, the motor
    torque included, carries coloured noise (a 2nd-order low-pass of white noise with
    a random corner of 20-300 Hz plus a white floor), of rms 0.1-1 % of the signal's (log-
    uniform; at 1-5 % the high modes of the long chains drowned: the noise is set by the
    signal's rms, which the low modes and the order lines hold).
    The simulation starts at rest and the first ``settle`` seconds (ten time constants of
    the slowest decaying mode, at most 20 s) are dropped, so no start transient is left.

Speed channel (``speed``): ``tacho`` (a 0-5 V sine, one period per revolution, of the
tacho shaft's angle: nominal turn plus its torsional vibration), ``encoder`` (that angle
in rad: the record's ``shaft_speed`` [rad/s] after reading) or ``none``;
:func:`speed_classes` gives half tacho, a quarter each of the others.

The truth: openTorsion's ``modal_analysis`` of the damped assembly (every mode, with its
damping ratio), and the drawn orders and shaft-speed range.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import opentorsion as ot
import pandas as pd
from scipy import linalg, signal

from tests.measured.bench_campaign import tacho_voltage

#: Band of the modes [Hz] and the excitation orders' band [Hz].
MODE_BAND, LINE_F_MAX = (5.0, 400.0), 350.0
#: Speed classes in the proportions half / quarter / quarter.
SPEEDS = ("tacho", "encoder", "tacho", "none")
#: The record's speed signal [rad/s] read from the encoder angle (``encoder`` cases).
ENCODER_SIGNAL = "shaft_speed"


class Case(NamedTuple):
    """One random bench: what the files encode and what was drawn.

    Attributes
    ----------
    name : str
        Record name (``case<index>``).
    speed : str
        ``tacho``, ``encoder`` or ``none``: the speed channel the files carry.
    frequency_hz, damping : ndarray
        The chain's modes [Hz] and damping ratios [-], ascending (openTorsion).
    orders : ndarray
        The excited integer orders of the tacho shaft [-], ascending.
    shaft_hz : (float, float)
        The tacho shaft's frequency at the start and the end of the record [Hz].
    excitation : dict
        ``f_lo``, ``f_hi`` [Hz] of the motor torque's band; ``notch`` (centre, width)
        [Hz] or None.
    spec : dict
        The ``measured:`` entry mapping the CSV (path relative to its folder).
    signals : dict of str -> ndarray
        The CSV's columns [SI] (``time`` [s] included).
    assembly : opentorsion.Assembly
        The chain, its damping matrix ``C`` the modal one.
    plant : tuple of ndarray
        Continuous A, B, C, D from (motor torque [N·m], line torque [N·m]) to (torque
        meter [N·m], output speed [rad/s], tacho-node angle [rad]).
    """

    name: str
    speed: str
    frequency_hz: np.ndarray
    damping: np.ndarray
    orders: np.ndarray
    shaft_hz: tuple[float, float]
    excitation: dict
    spec: dict
    signals: dict
    assembly: Any
    plant: tuple


def speed_classes(n: int) -> list[str]:
    """Speed channel of case ``0 .. n-1``: tacho, encoder, tacho, none, tacho, ..."""
    return [SPEEDS[i % len(SPEEDS)] for i in range(n)]


def _layout(rng: np.random.Generator) -> tuple[list[list[int]], list[tuple[int, int]]]:
    # node numbers per shaft line (the gear nodes included) and the gear pairs
    n_disks, n_stages = int(rng.integers(4, 13)), int(rng.integers(1, 4))
    per_line = 1 + rng.multinomial(n_disks - n_stages - 1, np.ones(n_stages + 1)
                                   / (n_stages + 1))
    lines, pairs, node = [], [], 0
    for i, n in enumerate(per_line):
        line = list(range(node, node + n + (i > 0) + (i < n_stages)))
        node = line[-1] + 1
        if i > 0:
            pairs.append((lines[-1][-1], line[0]))
        lines.append(line)
    return lines, pairs


def _assembly(lines: list[list[int]], pairs: list[tuple[int, int]], inertia: list[float],
              stiffness: np.ndarray, radius: np.ndarray, k_ground: float) -> ot.Assembly:
    # shafts between neighbours of a line, a pinion (R = 1) and its wheel per gear pair,
    # the motor disk (node 0) on its ground spring
    gear_nodes = {n for p in pairs for n in p}
    links = [(a, b) for line in lines for a, b in zip(line[:-1], line[1:], strict=True)]
    shafts = [ot.Shaft(a, b, k=k, I=0.0) for (a, b), k in zip(links, stiffness, strict=True)]
    disks = [ot.Disk(n, inertia[n], k=k_ground if n == 0 else 0.0)
             for n in range(len(inertia)) if n not in gear_nodes]
    gears = []
    for (p, w), r in zip(pairs, radius, strict=True):
        pinion = ot.Gear(p, inertia[p], 1.0)
        gears += [pinion, ot.Gear(w, inertia[w], r, parent=pinion)]
    return ot.Assembly(shafts, disk_elements=disks, gear_elements=gears)


def draw_chain(rng: np.random.Generator, min_gap_hz: float) -> tuple[ot.Assembly, list]:
    """A random chain whose modes lie in :data:`MODE_BAND` (module docstring).

    Parameters
    ----------
    rng : numpy.random.Generator
    min_gap_hz : float
        Smallest spacing of two modes [Hz] (twice the record's frequency resolution).

    Returns
    -------
    (opentorsion.Assembly, list of list of int)
        The chain with its modal damping matrix, and its node numbers per shaft line.
    """
    while True:
        lines, pairs = _layout(rng)
        n = lines[-1][-1] + 1
        gear_nodes = {x for p in pairs for x in p}
        inertia = [float(10 ** rng.uniform(-2.5, -0.5) if i in gear_nodes else
                         10 ** rng.uniform(-2.0, 0.5)) for i in range(n)]
        stiffness = 10 ** rng.uniform(4.0, 6.0, n - 1 - len(pairs))
        radius = rng.uniform(0.3, 4.0, len(pairs))
        k_ground = float(stiffness.min() * 10 ** rng.uniform(-2.0, 0.0))
        asm = _assembly(lines, pairs, inertia, stiffness, radius, k_ground)
        f = np.sqrt(np.abs(linalg.eigvals(asm.K, asm.M).real)) / (2 * np.pi)
        lo, hi = MODE_BAND[0] / f.min(), MODE_BAND[1] / f.max()
        if lo > hi:
            continue  # spans more than 80:1
        s = np.exp(rng.uniform(np.log(lo), np.log(hi)))  # frequency scale [-]
        if np.min(np.diff(np.sort(s * f))) < min_gap_hz:
            continue
        asm = _assembly(lines, pairs, inertia, s**2 * stiffness, radius, s**2 * k_ground)
        # a damping ratio per mode (independent draws: the order of C_modal's own
        # eig(K, M) they are taken in does not matter)
        zeta = 10 ** rng.uniform(np.log10(0.005), -1.0, asm.M.shape[0])
        asm.C = asm.C_modal(asm.M, asm.K, xi=zeta).real
        return asm, lines


def true_modes(assembly: ot.Assembly) -> tuple[np.ndarray, np.ndarray]:
    """Modes [Hz] and damping ratios [-], ascending: openTorsion's ``modal_analysis``."""
    wn, wd, zeta = (np.asarray(v, dtype=float) for v in assembly.modal_analysis())
    up = wd > 0  # one of each conjugate pair
    order = np.argsort(wn[up])
    return wn[up][order] / (2 * np.pi), zeta[up][order]


def plant(assembly: ot.Assembly, meter: tuple[int, int], k_meter: float, out_node: int,
          line_node: int, tacho_node: int) -> tuple[np.ndarray, ...]:
    """A, B, C, D: (motor torque on node 0, line torque on ``line_node``) [N·m] to (elastic
    torque of the shaft ``meter`` [N·m], speed of ``out_node`` [rad/s], angle of
    ``tacho_node`` [rad])."""
    a, b_all = assembly.state_space()[:2]
    t = assembly.T(assembly.E())  # node angles = t @ generalised coordinates
    n = t.shape[1]
    b = b_all @ t.T[:, [0, line_node]]
    c = np.zeros((3, 2 * n))
    c[0, :n] = k_meter * (t[meter[1]] - t[meter[0]])
    c[1, n:] = t[out_node]
    c[2, :n] = t[tacho_node]
    return a, b, c, np.zeros((3, 2))


def _coloured(rng: np.random.Generator, n: int, fs: float) -> np.ndarray:
    # unit-rms noise: a low-pass of random corner over a white floor
    sos = signal.butter(2, rng.uniform(20.0, 300.0), fs=fs, output="sos")
    e = signal.sosfilt(sos, rng.standard_normal(n))
    e = e / e.std() + 0.3 * rng.standard_normal(n)
    return e / e.std()


def simulate(seed: int, speed: str, *, fs: float = 2000.0, duration: float = 40.0,
             min_gap_hz: float = 1.0, name: str = "case") -> Case:
    """Draw a chain and its record (module docstring); nothing written.

    Parameters
    ----------
    seed : int
        Seed of every draw of the case.
    speed : {"tacho", "encoder", "none"}
        The speed channel the record carries.
    fs : float
        Sample rate of the record [Hz].
    duration : float
        Record length kept [s].
    min_gap_hz : float
        Smallest spacing of two modes of the chain [Hz].
    name : str
        Record name.
    """
    if speed not in SPEEDS:
        raise ValueError(f"speed must be one of {sorted(set(SPEEDS))}; got {speed!r}")
    rng = np.random.default_rng(seed)
    asm, lines = draw_chain(rng, min_gap_hz)
    f_modes, zeta = true_modes(asm)
    # sensors and excitation points
    shafts = [(s.nl, s.nr, s.k) for s in asm.shaft_elements]
    a_m, b_m, k_m = shafts[int(rng.integers(len(shafts)))]
    out_node = int(rng.choice(lines[-1]))
    tacho_line = lines[int(rng.integers(len(lines)))]
    tacho_node, line_node = (int(v) for v in rng.choice(tacho_line, 2))
    sys_c = plant(asm, (a_m, b_m), k_m, out_node, line_node, tacho_node)
    # excitation: band-limited (and maybe notched) motor torque, angle-locked lines
    settle = min(20.0, 10.0 / float(np.min(2 * np.pi * f_modes * zeta)))
    n_settle, n = int(round(settle * fs)), int(round(duration * fs))
    t = np.arange(n_settle + n) / fs
    f_lo, f_hi = rng.uniform(5.0, 60.0), rng.uniform(150.0, 350.0)
    motor = signal.sosfilt(signal.butter(4, [f_lo, f_hi], "bandpass", fs=fs, output="sos"),
                           rng.standard_normal(t.size))
    notch = None
    if rng.random() < 0.5:
        centre, width = rng.uniform(f_lo + 20.0, f_hi - 20.0), rng.uniform(10.0, 40.0)
        notch = (float(centre), float(width))
        motor = signal.sosfilt(signal.butter(4, [centre - width / 2, centre + width / 2],
                                             "bandstop", fs=fs, output="sos"), motor)
    motor *= 100.0 / motor.std()  # 100 N·m rms (the chain is linear: the scale is free)
    f0 = rng.uniform(5.0, 30.0)
    f_shaft = f0 * (1.0 + rng.uniform(0.0, 0.02) * t / t[-1])  # [Hz]
    theta = 2 * np.pi * np.cumsum(f_shaft) / fs  # nominal shaft angle [rad]
    k_max = int(LINE_F_MAX // f_shaft[-1])
    orders = np.sort(rng.choice(np.arange(1, k_max + 1), min(int(rng.integers(3, 9)), k_max),
                                replace=False)).astype(float)
    amps = 100.0 * 10 ** rng.uniform(-1.0, 0.0, orders.size)
    phases = rng.uniform(0, 2 * np.pi, orders.size)
    lines_torque = (amps * np.sin(np.outer(theta, orders) + phases)).sum(axis=1)
    sysd = signal.cont2discrete(sys_c, 1.0 / fs, method="zoh")
    _, y, _ = signal.dlsim(sysd[:4] + (1.0 / fs,), np.column_stack([motor, lines_torque]))
    keep = slice(n_settle, None)
    y, motor, theta, t = y[keep], motor[keep], theta[keep], t[:n]
    shaft_angle = theta - theta[0] + y[:, 2]  # the vibration rides on the nominal turn
    measured = {}
    for key, v in (("motor torque", motor), ("torque meter", y[:, 0]),
                   ("output speed", y[:, 1])):
        measured[key] = v + 10 ** rng.uniform(-3.0, -2.0) * v.std() * _coloured(rng, n, fs)
    signals = {"time": t, **measured}
    spec_signals = {"motor_torque": {"file": "daq", "channel": "motor torque", "unit": "N*m"},
                    "torque_meter": {"file": "daq", "channel": "torque meter", "unit": "N*m"},
                    "output_speed": {"file": "daq", "channel": "output speed",
                                     "unit": "rad/s"}}
    if speed == "tacho":
        signals["tacho"] = tacho_voltage(t, np.gradient(shaft_angle, t), 1)
        spec_signals["tacho"] = {"file": "daq", "channel": "tacho", "quantity": "tacho",
                                 "pulses_per_rev": 1}
    elif speed == "encoder":
        signals["shaft angle"] = shaft_angle
        spec_signals[ENCODER_SIGNAL] = {"file": "daq", "channel": "shaft angle", "unit": "rad",
                                       "quantity": "angle"}
    spec = {"files": {"daq": {"path": f"{name}.csv", "time": "time"}}, "sample_rate": fs,
            "signals": spec_signals}
    if speed == "tacho":
        spec["orders"] = orders.tolist()
    return Case(name, speed, f_modes, zeta, orders, (float(f_shaft[n_settle]),
                                                     float(f_shaft[-1])),
                {"f_lo": float(f_lo), "f_hi": float(f_hi), "notch": notch}, spec, signals,
                asm, sys_c)


def write_case(folder: Path, case: Case) -> Path:
    """Write the case's CSV into ``folder`` (created); return the folder (the spec's base)."""
    folder.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(case.signals).to_csv(folder / case.spec["files"]["daq"]["path"], index=False,
                                      float_format="%.10g")
    return folder


def cases(n: int, seed: int, **kw: Any) -> list[Case]:
    """``n`` cases, case ``i`` seeded by ``(seed, i)`` and with speed class
    :func:`speed_classes` ``[i]``; ``kw`` to :func:`simulate`."""
    return [simulate(int(np.random.SeedSequence([seed, i]).generate_state(1)[0]), speed,
                     name=f"case{i:02d}", **kw)
            for i, speed in enumerate(speed_classes(n))]
