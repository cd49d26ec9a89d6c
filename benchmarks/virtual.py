"""Virtual torque sensor (gbpipe.virtual): speed on a 50-state chain, accuracy over seeds.

Part 1, speed: a line of 26 openTorsion disks (49 mechanical states once the rigid-body
angle is removed, plus the unknown load: 50), 60 s at 1 kHz, two encoder speeds and the
motor torque; CPU time of the estimator (steady-state gains, GLS offsets and initial
state, filter and RTS smoother of every shaft torque) per second of data, against the
target 0.01 s/s; and of the noise fit (maximum likelihood on the innovations of the first
10 s), reported apart (it runs once per record on its noise window).

Part 2, accuracy: 20 seeds of random 8-disk chains (tests/virtual/chains.py: truth
simulated with scipy from openTorsion's matrices), the torque of the middle shaft, which
no sensor measures: fit [%] against the truth and the share of samples inside the 95 %
band (both on the steady part: the filter's start and the smoother's end transients left
out), with the true model and with every stiffness and inertia of the estimator's model off
by a random ±10 %.

Usage: ``OMP_NUM_THREADS=1 python benchmarks/virtual.py [n_seeds]`` (0: the speed alone).
"""

from __future__ import annotations

import copy
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gbpipe.lti import fit_percent  # noqa: E402
from gbpipe.model import build_chain  # noqa: E402
from gbpipe.virtual import Z95, estimation_model, fit_noise, smooth  # noqa: E402
from tests.virtual.chains import simulate_chain  # noqa: E402

SENSORS = ["speed_first", "speed_last"]


def perturbed(desc: dict, rng: np.random.Generator, share: float) -> dict:
    """``desc`` with every disk inertia and shaft stiffness scaled by ±``share``."""
    out = copy.deepcopy(desc)
    for d in out["disks"].values():
        d["inertia"] *= 1 + share * rng.choice([-1, 1])
    for s in out["shafts"]:
        s["stiffness"] *= 1 + share * rng.choice([-1, 1])
    return out


def run(rec, desc: dict, shaft: int, noise_samples: int
        ) -> tuple[float, float, float, float, float]:
    """Fit [%], band coverage [-], estimator CPU [s], noise-fit CPU [s] of one record, and
    the band's half width [N·m]."""
    chain = build_chain(desc)
    last = f"n{len(desc['disks']) - 1}"
    t0 = time.process_time()
    model = estimation_model(chain, SENSORS, [f"torque_shaft{shaft}"], [last], rec.dt)
    y = np.column_stack([rec.y[s] for s in SENSORS])
    nf = fit_noise(model, y[:noise_samples], rec.u_measured[:noise_samples])
    t1 = time.process_time()
    est = smooth(model, nf.noise, y, rec.u_measured)
    t2 = time.process_time()
    keep = est.steady
    truth = rec.torque[keep, shaft]
    z, sd = est.z[keep, 0], est.sd[0]
    return (float(fit_percent(truth, z)[0]), float(np.mean(np.abs(z - truth) <= Z95 * sd)),
            t2 - t1, t1 - t0, float(Z95 * sd))


def main(n_seeds: int = 20) -> None:
    rec = simulate_chain(100, n_disks=25, duration=60.0)
    fit, cov, t_est, t_noise, _ = run(rec, rec.description, 12, 10_000)
    seconds = 60.0
    print(f"speed: 50-state chain, 60 s at 1 kHz: estimator {t_est:.3f} s CPU = "
          f"{t_est / seconds:.4f} s per s of data (target 0.01); noise fit on 10 s "
          f"{t_noise:.2f} s CPU; fit {fit:.2f} %, coverage {cov:.3f}")
    if n_seeds == 0:    # the speed alone
        return
    rows = {"true model": [], "model ±10 %": []}
    for seed in range(n_seeds):
        rec = simulate_chain(seed, n_disks=8, duration=20.0)
        r = run(rec, rec.description, 3, 10_000)
        rows["true model"].append((r[0], r[1], r[4]))
        wrong = perturbed(rec.description, np.random.default_rng(1000 + seed), 0.10)
        r = run(rec, wrong, 3, 10_000)
        rows["model ±10 %"].append((r[0], r[1], r[4]))
    for name, r in rows.items():
        a = np.array(r)
        print(f"{name}: fit min {a[:, 0].min():.2f} median {np.median(a[:, 0]):.2f} % ; "
              f"coverage min {a[:, 1].min():.3f} median {np.median(a[:, 1]):.3f} "
              f"max {a[:, 1].max():.3f}; band half width median {np.median(a[:, 2]):.2f} "
              f"N m ({n_seeds} seeds)")
    widen = np.array(rows["model ±10 %"])[:, 2] / np.array(rows["true model"])[:, 2]
    print(f"band width, model ±10 % over true model: median {np.median(widen):.2f}, "
          f"min {widen.min():.2f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 20)
