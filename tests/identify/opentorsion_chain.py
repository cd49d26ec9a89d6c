"""A torsional chain nobody modelled in gbpipe, as bench files: the modal stage's test case.

The chain is built with openTorsion (an independent library: its own element matrices and
gear-constraint reduction), its parameters unrelated to gbpipe's gearbox: seven nodes
(motor, coupling hub, pinion | wheel, two hubs, a load), a 1:3 gear pair between the
pinion and the wheel (one constraint: six degrees of freedom), the motor held to ground
by a soft, well-damped spring (a speed loop's stiffness: no rigid-body integrator). Its
M, C, K come from ``Assembly.M``, ``Assembly.C``, ``Assembly.K``; the state matrix from
``Assembly.state_space``; the record from :func:`scipy.signal.dlsim` of its exact
zero-order-hold discretisation (:func:`scipy.signal.cont2discrete`), not from gbpipe.

Excitation: a broadband motor torque (seeded white noise, measured) plus angle-locked
lines of a shaft turning at a speed that sweeps ``shaft_hz`` over the record (default
``SHAFT_HZ``): shaft orders 1-3 (unbalance, misalignment) as a torque on the pinion and
as motor-torque ripple, and a mesh order (the pinion's teeth, default ``MESH_ORDER``) on
the pinion. Sensors:
the motor torque, a torque meter on the motor coupling (the shaft's elastic torque) and
the load speed, each with seeded white noise; the shaft's tachometer is a 0-5 V sine (one
period per revolution) whose rising mid-level crossings are the pulses.

The truth is the chain's modes: :func:`scipy.linalg.eig` of its state matrix.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
import opentorsion as ot
import pandas as pd
from scipy import linalg, signal

#: Inertias of the seven nodes [kg m^2] (node 2 the pinion, node 3 the wheel).
INERTIA = (0.8, 0.05, 0.02, 0.9, 0.3, 0.05, 2.5)
#: Stiffness of the motor's ground spring, then of the shafts 0-1, 1-2, 3-4, 4-5, 5-6 [N m/rad].
STIFFNESS = (300.0, 4.0e4, 2.0e4, 4.0e5, 2.5e5, 1.5e5)
#: Damping ratio of each element about its own two-inertia mode [-] (sets its c).
ZETA = (0.3, 0.04, 0.05, 0.03, 0.03, 0.03)
#: Pinion and wheel radii [mm] (a 1:3 reduction).
RADII = (1.0, 3.0)
SHAFTS = ((0, 1), (1, 2), (3, 4), (4, 5), (5, 6))
#: The tacho shaft's speed sweeps from the first to the second value over the record [Hz].
SHAFT_HZ = (10.0, 10.4)
#: The mesh order of the tacho shaft (the pinion's teeth) [-].
MESH_ORDER = 23.0
#: Angle-locked torque amplitudes on the pinion per shaft order [N m], and of the mesh.
LINES = {1.0: 30.0, 2.0: 20.0, 3.0: 15.0}
MESH_AMPLITUDE = 25.0
#: Motor-torque ripple per shaft order [N m] (measured with the motor torque).
RIPPLE = {1.0: 10.0, 2.0: 6.0}


class ChainTruth(NamedTuple):
    """What the bench files encode.

    Attributes
    ----------
    frequency_hz, damping : ndarray
        The chain's modes [Hz] and damping ratios [-], ascending.
    spec : dict
        The ``measured:`` entry mapping the files (paths relative to the folder).
    orders : tuple of float
        The excitation orders of the tacho shaft [-].
    shaft_hz : (float, float)
        The tacho shaft's frequency at the start and the end of the record [Hz].
    signals : dict of str -> ndarray
        The columns written (:func:`simulate`), file channel name -> values [SI].
    """

    frequency_hz: np.ndarray
    damping: np.ndarray
    spec: dict
    orders: tuple[float, ...]
    shaft_hz: tuple[float, float]
    signals: dict


def chain() -> ot.Assembly:
    """The openTorsion assembly of the chain (shaft damping c = 2 zeta sqrt(k J_eq))."""
    j = INERTIA
    shafts = []
    for (a, b), k, z in zip(SHAFTS, STIFFNESS[1:], ZETA[1:], strict=True):
        j_eq = j[a] * j[b] / (j[a] + j[b])
        shafts.append(ot.Shaft(a, b, k=k, I=0.0, c=2 * z * np.sqrt(k * j_eq)))
    disks = [ot.Disk(0, j[0], c=2 * ZETA[0] * np.sqrt(STIFFNESS[0] * j[0]), k=STIFFNESS[0])]
    disks += [ot.Disk(n, j[n]) for n in (1, 4, 5, 6)]
    pinion = ot.Gear(2, j[2], RADII[0])
    wheel = ot.Gear(3, j[3], RADII[1], parent=pinion)
    return ot.Assembly(shafts, disk_elements=disks, gear_elements=[pinion, wheel])


def true_modes(assembly: ot.Assembly) -> tuple[np.ndarray, np.ndarray]:
    """Modes [Hz] and damping ratios [-] from :func:`scipy.linalg.eig` of the state matrix."""
    a = assembly.state_space()[0]
    lam = linalg.eig(a, right=False)
    lam = lam[lam.imag > 0]
    f = np.abs(lam) / (2 * np.pi)
    order = np.argsort(f)
    return f[order], (-lam.real / np.abs(lam))[order]


def plant(assembly: ot.Assembly) -> tuple[np.ndarray, ...]:
    """A, B, C, D from the motor torque (node 0) and the pinion torque (node 2) [N m] to
    the torque meter (elastic torque of shaft 0-1) [N m] and the load speed (node 6) [rad/s]."""
    a, b_all = assembly.state_space()[:2]
    t = assembly.T(assembly.E())  # full node angles = t @ reduced coordinates
    n = t.shape[1]
    b = b_all @ t.T[:, [0, 2]]  # node torques -> generalised forces
    c = np.zeros((2, 2 * n))
    c[0, :n] = STIFFNESS[1] * (t[1] - t[0])
    c[1, n:] = t[6]
    return a, b, c, np.zeros((2, 2))


def simulate(fs: float, duration: float, seed: int, shaft_hz: tuple[float, float] = SHAFT_HZ,
             mesh_order: float = MESH_ORDER) -> dict[str, np.ndarray]:
    """The chain's signals [SI] on a uniform grid at ``fs`` [Hz] for ``duration`` [s]."""
    rng = np.random.default_rng(seed)
    assembly = chain()
    t = np.arange(int(round(duration * fs))) / fs
    f_shaft = shaft_hz[0] + (shaft_hz[1] - shaft_hz[0]) * t / t[-1]
    lines = {**LINES, mesh_order: MESH_AMPLITUDE}
    theta = 2 * np.pi * np.cumsum(f_shaft) / fs  # tacho shaft angle [rad]
    phases = rng.uniform(0, 2 * np.pi, len(lines) + len(RIPPLE))
    ripple = sum(a * np.sin(k * theta + p) for (k, a), p in zip(RIPPLE.items(), phases[:2],
                                                                 strict=True))
    motor = 100.0 * rng.standard_normal(t.size) + ripple
    pinion = sum(a * np.sin(k * theta + p) for (k, a), p in zip(lines.items(), phases[2:],
                                                                strict=True))
    sysd = signal.cont2discrete(plant(assembly), 1.0 / fs, method="zoh")
    _, y, _ = signal.dlsim(sysd[:4] + (1.0 / fs,), np.column_stack([motor, pinion]), t)
    noise = 0.02 * y.std(axis=0) * rng.standard_normal(y.shape)
    return {"time": t, "motor torque": motor + 0.5 * rng.standard_normal(t.size),
            "torque meter": y[:, 0] + noise[:, 0], "load speed": y[:, 1] + noise[:, 1],
            "tacho": 2.5 + 2.5 * np.sin(theta + 0.3)}


def write_bench(folder: Path, *, fs: float = 2000.0, duration: float = 60.0, seed: int = 3,
                shaft_hz: tuple[float, float] = SHAFT_HZ, mesh_order: float = MESH_ORDER
                ) -> ChainTruth:
    """Write the chain's record as a CSV bench file in ``folder``; return the truth.

    Parameters
    ----------
    folder : Path
        Where ``chain.csv`` goes (created).
    fs : float
        Logging rate [Hz].
    duration : float
        Record length [s].
    seed : int
        Seed of the excitation, the line phases and the sensor noise.
    shaft_hz, mesh_order
        Speed sweep of the tacho shaft [Hz] and the mesh order [-] (:func:`simulate`).
    """
    folder.mkdir(parents=True, exist_ok=True)
    signals = simulate(fs, duration, seed, shaft_hz, mesh_order)
    pd.DataFrame(signals).to_csv(folder / "chain.csv", index=False, float_format="%.12g")
    f, z = true_modes(chain())
    spec = {"files": {"daq": {"path": "chain.csv", "time": "time"}},
            "sample_rate": fs,
            "signals": {"motor_torque": {"file": "daq", "channel": "motor torque",
                                         "unit": "N*m"},
                        "torque_meter": {"file": "daq", "channel": "torque meter",
                                         "unit": "N*m"},
                        "load_speed": {"file": "daq", "channel": "load speed",
                                       "unit": "rad/s"},
                        "tacho": {"file": "daq", "channel": "tacho", "quantity": "tacho",
                                  "pulses_per_rev": 1}},
            "orders": [mesh_order]}
    return ChainTruth(f, z, spec, (*sorted(LINES), mesh_order), tuple(shaft_hz), signals)
