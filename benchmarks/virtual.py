"""Virtual torque sensor (gbpipe.virtual): speed on a 50-state chain, accuracy over seeds.

Part 1, speed: a line of 26 openTorsion disks (49 mechanical states once the rigid-body
angle is removed, plus the unknown load: 50), 60 s at 1 kHz, two encoder speeds and the
motor torque; CPU time of the estimator (steady-state gains, GLS offsets and initial
state, filter and RTS smoother of every shaft torque) per second of data, against the
target 0.01 s/s; and of the noise fit (maximum likelihood on the innovations of the first
10 s), reported apart (it runs once per record on its noise window).

Part 2, accuracy: 20 seeds of random 8-disk chains (tests/virtual/chains.py: truth
simulated with scipy from openTorsion's matrices), the torque of the middle shaft, which
no sensor measures: per seed the fit [%] against the truth beside the fit the estimator's
own band predicts, ``100 (1 − σ/std T)`` (σ the steady smoothed standard deviation: the
information bound of the sensor set), and the share of samples inside the 95 % band (both
on the steady part: the filter's start and the smoother's end transients left out); with
the true model (noise fitted, and the true noise levels), with a speed sensor added beside
the shaft, and with every stiffness and inertia of the estimator's model off by a random
±10 %. For a seed below 95 %: the RMS error against σ, a record twice as long, and the
bound of other sensor sets and noise levels.

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
from gbpipe.virtual import (  # noqa: E402
    Z95,
    NoiseModel,
    estimation_model,
    fit_noise,
    gains,
    smooth,
)
from tests.virtual.chains import LOAD_RATE, simulate_chain  # noqa: E402

SENSORS = ["speed_first", "speed_last"]


def perturbed(desc: dict, rng: np.random.Generator, share: float) -> dict:
    """``desc`` with every disk inertia and shaft stiffness scaled by ±``share``."""
    out = copy.deepcopy(desc)
    for d in out["disks"].values():
        d["inertia"] *= 1 + share * rng.choice([-1, 1])
    for s in out["shafts"]:
        s["stiffness"] *= 1 + share * rng.choice([-1, 1])
    return out


def run(rec, desc: dict, shaft: int, noise_samples: int, sensors: list[str] = SENSORS,
        true_noise: bool = False) -> dict:
    """One record: fit [%] against the truth, the fit its own band predicts [%] (``100 (1 −
    σ/std T)``, σ the smoothed steady standard deviation: the information bound of the
    sensor set), the spread of the achieved fit over four quarters of the steady part [%],
    band coverage [-], band half width [N·m], estimator and noise-fit CPU [s].
    ``true_noise``: the simulated noise levels instead of the maximum-likelihood ones."""
    chain = build_chain(desc)
    last = f"n{len(desc['disks']) - 1}"
    t0 = time.process_time()
    model = estimation_model(chain, sensors, [f"torque_shaft{shaft}"], [last], rec.dt)
    y = np.column_stack([rec.y[s] for s in sensors])
    if true_noise:
        # no model error in the truth: a negligible coordinate torque keeps P positive
        noise = NoiseModel(np.array([rec.noise_sd[s] for s in sensors]),
                           np.array([rec.noise_sd["motor"]]), np.array([LOAD_RATE]), 1e-6)
    else:
        noise = fit_noise(model, y[:noise_samples], rec.u_measured[:noise_samples]).noise
    t1 = time.process_time()
    est = smooth(model, noise, y, rec.u_measured)
    t2 = time.process_time()
    keep = est.steady
    truth = rec.torque[keep, shaft]
    z, sd = est.z[keep, 0], est.sd[0]
    quarters = [fit_percent(a, b)[0] for a, b in zip(np.array_split(truth, 4),
                                                     np.array_split(z, 4), strict=True)]
    return {"fit": float(fit_percent(truth, z)[0]),
            "predicted": float(100 * (1 - sd / np.std(truth))),
            "spread": float(np.std(quarters) / 2),
            "coverage": float(np.mean(np.abs(z - truth) <= Z95 * sd)),
            "half": float(Z95 * sd), "t_est": t2 - t1, "t_noise": t1 - t0,
            "steady": float(keep.mean()), "rms": float(np.sqrt(np.mean((z - truth) ** 2))),
            "sigma": float(sd), "std": float(np.std(truth))}


def bounds(rec, shaft: int, std: float) -> dict[str, float]:
    """Predicted fit [%] ``100 (1 − σ/std)`` of other sensor sets and noise levels (the
    true ones as simulated; σ from the Riccati and Lyapunov solutions alone): what it
    takes to move the bound of the two end speeds."""
    chain = build_chain(rec.description)
    sd = rec.noise_sd

    def fit(sensors: list[str], speed: float = 1.0, load: float = 1.0) -> float:
        model = estimation_model(chain, sensors, [f"torque_shaft{shaft}"],
                                 [f"n{len(rec.description['disks']) - 1}"], rec.dt)
        noise = NoiseModel(np.array([sd[s] * (speed if s.startswith("speed") else 1)
                                     for s in sensors]), np.array([sd["motor"]]),
                           np.array([LOAD_RATE * load]), 1e-6)
        return 100 * (1 - np.sqrt(model.Cz[0] @ gains(model, noise).Ps @ model.Cz[0]) / std)

    return {"the end speeds": fit(SENSORS),
            "+ a middle speed": fit([*SENSORS, "speed_mid"]),
            "+ a torque sensor on the first shaft": fit([*SENSORS, "torque_first"]),
            "speed noise / 10": fit(SENSORS, speed=0.1),
            "a load 10 times steadier": fit(SENSORS, load=0.1)}


def main(n_seeds: int = 20) -> None:
    rec = simulate_chain(100, n_disks=25, duration=60.0)
    r = run(rec, rec.description, 12, 10_000)
    seconds = 60.0
    print(f"speed: 50-state chain, 60 s at 1 kHz: estimator {r['t_est']:.3f} s CPU = "
          f"{r['t_est'] / seconds:.4f} s per s of data (target 0.01); noise fit on 10 s "
          f"{r['t_noise']:.2f} s CPU; fit {r['fit']:.2f} %, coverage {r['coverage']:.3f}")
    if n_seeds == 0:    # the speed alone
        return
    rows = {"true model": [], "model ±10 %": []}
    print("per seed, the middle shaft's torque: fit achieved ± its spread over the four "
          "quarters / predicted by the band [%], coverage [-], steady share [-]\n"
          "seed | true model, noise fitted | true model, true noise | + a middle speed "
          "sensor (true noise) | model ±10 %, noise fitted")
    for seed in range(n_seeds):
        rec = simulate_chain(seed, n_disks=8, duration=20.0)
        a = run(rec, rec.description, 3, 10_000)
        b = run(rec, rec.description, 3, 10_000, true_noise=True)
        # the same chain and truth, a speed sensor added at disk 4 (next to the shaft)
        mid = simulate_chain(seed, n_disks=8, duration=20.0,
                             sensors=("speed_first", "speed_last", "speed_mid", "torque_first"))
        c = run(mid, mid.description, 3, 10_000, [*SENSORS, "speed_mid"], true_noise=True)
        wrong = perturbed(rec.description, np.random.default_rng(1000 + seed), 0.10)
        d = run(rec, wrong, 3, 10_000)
        rows["true model"].append(a)
        rows["model ±10 %"].append(d)
        print(f"{seed:4d} | " + " | ".join(
            f"{x['fit']:6.2f} ± {x['spread']:.2f} / {x['predicted']:6.2f}, {x['coverage']:.3f}"
            for x in (a, b, c, d)) + f" | {a['steady']:.2f}")
        if a["fit"] < 95.0:
            # the bound is per sample (σ [N·m]): a record twice as long has the same RMS
            # error; its fit moves only with std T (the random-walk load wanders further)
            long = simulate_chain(seed, n_disks=8, duration=40.0)
            e = run(long, long.description, 3, 10_000, true_noise=True)
            print(f"     seed {seed} below 95 %: RMS error {b['rms']:.2f} N m, σ {b['sigma']:.2f}"
                  f" N m (true noise); 40 s record: RMS error {e['rms']:.2f}, σ "
                  f"{e['sigma']:.2f} N m, fit {e['fit']:.2f} / {e['predicted']:.2f} %")
            print("     predicted fit with: " + ", ".join(
                f"{k} {v:.2f} %" for k, v in bounds(mid, 3, b["std"]).items()))
    for name, r in rows.items():
        fit = np.array([x["fit"] for x in r])
        gap = fit - np.array([x["predicted"] for x in r])
        cov = np.array([x["coverage"] for x in r])
        half = np.array([x["half"] for x in r])
        print(f"{name}: fit min {fit.min():.2f} median {np.median(fit):.2f} % (achieved − "
              f"predicted: median {np.median(gap):+.2f}, min {gap.min():+.2f}); coverage min "
              f"{cov.min():.3f} median {np.median(cov):.3f} max {cov.max():.3f}; band half "
              f"width median {np.median(half):.2f} N m ({n_seeds} seeds)")
    widen = (np.array([x["half"] for x in rows["model ±10 %"]])
             / np.array([x["half"] for x in rows["true model"]]))
    print(f"band width, model ±10 % over true model: median {np.median(widen):.2f}, "
          f"min {widen.min():.2f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 20)
