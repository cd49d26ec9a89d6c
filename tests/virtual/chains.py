"""Random torsional chains with a known truth, for the virtual-sensor tests and benchmark.

Each chain is an openTorsion assembly (disks on a line joined by shafts, the first disk
driven by a motor whose torque is measured with noise, an unknown load on the last disk);
the truth is simulated with scipy alone from openTorsion's own M, C, K
(``scipy.signal.cont2discrete`` + ``scipy.signal.dlsim``: exact zero-order hold,
independent of gbpipe's simulator), so the estimator, which reads the description gbpipe
builds from the assembly (:func:`gbpipe.model.opentorsion_io.from_assembly`), is judged
against another code's model.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import opentorsion as ot
from scipy import signal

from gbpipe.model.opentorsion_io import from_assembly

#: Random-walk intensity of the unknown load [N·m/√s].
LOAD_RATE = 30.0


class ChainRecord(NamedTuple):
    """A simulated record with its truth.

    Attributes
    ----------
    description : dict
        ``drivetrain:`` description (with the motor and the sensors).
    dt : float
        Sample interval [s].
    u_measured : ndarray (N, 1)
        Motor torque as measured (noise added) [N·m].
    y : dict
        Sensor name -> measured signal (noise added) [rad/s or N·m].
    torque : ndarray (N, n_shafts)
        True shaft torques [N·m] (``k·twist + c·twist rate``, twist ``θ_a − θ_b``).
    load : ndarray (N,)
        True load torque [N·m] on the last disk.
    noise_sd : dict
        Sensor name (and ``motor``) -> the standard deviation of its white noise as
        simulated [its unit]: the true noise levels.
    """

    description: dict
    dt: float
    u_measured: np.ndarray
    y: dict
    torque: np.ndarray
    load: np.ndarray
    noise_sd: dict


def random_assembly(rng: np.random.Generator, n_disks: int) -> ot.Assembly:
    """A line of ``n_disks`` disks (0.05–1 kg·m²) joined by shafts (2e4–2e5 N·m/rad,
    damping ratio 1–3 % of each shaft with its two neighbours)."""
    inertia = rng.uniform(0.05, 1.0, n_disks)
    k = rng.uniform(2e4, 2e5, n_disks - 1)
    zeta = rng.uniform(0.01, 0.03, n_disks - 1)
    jeq = inertia[:-1] * inertia[1:] / (inertia[:-1] + inertia[1:])
    c = 2 * zeta * np.sqrt(k * jeq)
    shafts = [ot.Shaft(i, i + 1, k=float(k[i]), c=float(c[i])) for i in range(n_disks - 1)]
    disks = [ot.Disk(i, float(inertia[i])) for i in range(n_disks)]
    return ot.Assembly(shafts, disks)


def simulate_chain(seed: int, n_disks: int = 8, duration: float = 10.0, fs: float = 1000.0,
                   noise_share: float = 0.01, sensors: tuple[str, ...] = ("speed_first",
                                                                         "speed_last"),
                   assembly: ot.Assembly | None = None) -> ChainRecord:
    """Simulate a random chain (or ``assembly``) driven by a measured motor torque on disk 0
    and an unknown load on the last disk.

    The motor torque: a mean of 200 N·m plus band-limited (0–50 Hz) random torque of
    50 N·m rms; the load: −200 N·m plus a random walk of ``LOAD_RATE`` (an unknown,
    slowly changing braking torque, held over each sample). Sensor and motor-torque
    noise: white, ``noise_share`` of each signal's dynamic rms. ``sensors``:
    ``speed_first``, ``speed_last``, ``speed_mid`` (disk ``n_disks // 2``), ``torque_first``
    (the first shaft).
    """
    rng = np.random.default_rng(seed)
    asm = assembly if assembly is not None else random_assembly(rng, n_disks)
    M, K, C = asm.M, asm.K, asm.C
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    B = np.zeros((2 * n, 2))
    B[n:, 0] = Minv[:, 0]
    B[n:, 1] = Minv[:, -1]
    N = int(round(duration * fs))
    b, a = signal.butter(4, 50.0, fs=fs)
    drive = signal.lfilter(b, a, rng.standard_normal(N))
    drive = 200.0 + 50.0 * drive / drive.std()
    load = -200.0 + LOAD_RATE * np.cumsum(rng.standard_normal(N)) * np.sqrt(1.0 / fs)
    # start at rest with the mean torques' transient: the estimator estimates the state
    ad, bd, *_ = signal.cont2discrete((A, B, np.eye(2 * n), np.zeros((2 * n, 2))),
                                      1.0 / fs, method="zoh")
    _, _, x = signal.dlsim((ad, bd, np.eye(2 * n), np.zeros((2 * n, 2)), 1.0 / fs),
                           np.column_stack([drive, load]))
    theta, omega = x[:, :n], x[:, n:]
    torque = np.column_stack([
        s.k * (theta[:, s.nl] - theta[:, s.nr]) + s.c * (omega[:, s.nl] - omega[:, s.nr])
        for s in asm.shaft_elements])
    clean = {"speed_first": omega[:, 0], "speed_last": omega[:, -1],
             "speed_mid": omega[:, n // 2], "torque_first": torque[:, 0]}
    sd = {s: noise_share * np.std(v) for s, v in clean.items()}
    sd["motor"] = noise_share * np.std(drive)
    y = {s: clean[s] + sd[s] * rng.standard_normal(N) for s in sensors}
    desc = from_assembly(asm)
    last = f"n{n - 1}"
    desc["motors"] = [{"name": "drive", "node": "n0", "sign": 1}]
    desc["sensors"] = [{"name": "speed_first", "speed": "n0"},
                       {"name": "speed_last", "speed": last},
                       {"name": "speed_mid", "speed": f"n{n // 2}"},
                       {"name": "torque_first", "torque": "shaft0", "sign": 1}]
    u = drive + sd["motor"] * rng.standard_normal(N)
    return ChainRecord(desc, 1.0 / fs, u[:, None], y, torque, load,
                       {s: sd[s] for s in (*sensors, "motor")})
