"""Benchmark of gbpipe.harmonics.residual: time and peak memory vs record length.

A 400 -> 1120 rpm linear sweep sampled at 10 kHz (HSS orders 1-3, a 5.3569 mesh family,
white noise), one pulse per HSS revolution; records of 0.3, 0.6 and 1.2 M samples
(30, 60, 120 s: same speed range, so the cost per sample is the same). For each variant
(HSS: cycle order 1; mesh2: 5.3569; carrier2: 5.3569/114) the table gives the best of
``--repeat`` wall-clock times and the peak memory traced by :mod:`tracemalloc` (numpy
and scipy.ndimage allocate through it) in a separate run, in MB and bytes per input
sample. Goal: <= 0.3 s at 1.2 M samples, memory linear in record length.

Run: ``OMP_NUM_THREADS=1 python benchmarks/tsa.py`` (add ``--joint`` for the joint
removal of hss + mesh2, which is ~2 x passes slower).
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np

from gbpipe.harmonics import residual, residual_joint

MESH2 = 5.3569
VARIANTS = {"hss": 1.0, "mesh2": MESH2, "carrier2": MESH2 / 114}


def sweep(n: int, fs: float = 10_000.0, rpm0: float = 400.0, rpm1: float = 1120.0,
          seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Signal and pulse times of a linear speed sweep of n samples."""
    rng = np.random.default_rng(seed)
    T = n / fs
    t = np.arange(n) / fs
    a = 2 * np.pi * (rpm1 - rpm0) / 60 / (2 * T)  # theta = a t^2 + b t
    b = 2 * np.pi * rpm0 / 60
    theta = a * t**2 + b * t
    x = (0.3 * np.cos(theta) + 0.2 * np.cos(2 * theta) + np.cos(3 * theta)
         + 0.7 * np.cos(MESH2 * theta) + 0.3 * np.cos(2 * MESH2 * theta)
         + 0.3 * rng.standard_normal(n))
    k = np.arange(1, int(theta[-1] / (2 * np.pi)))
    pulses = (-b + np.sqrt(b * b + 4 * a * 2 * np.pi * k)) / (2 * a)
    return x, pulses


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--joint", action="store_true", help="also time residual_joint")
    args = ap.parse_args()
    print(f"{'variant':>9} {'samples':>9} {'time [s]':>9} {'peak [MB]':>10} "
          f"{'B/sample':>9} {'M':>6} {'cycles':>7}")
    for name, c in VARIANTS.items():
        for n in (300_000, 600_000, 1_200_000):
            x, p = sweep(n)
            best = np.inf
            for _ in range(args.repeat):
                t = time.perf_counter()
                _, info = residual(x, 10_000.0, p, c, return_info=True)
                best = min(best, time.perf_counter() - t)
            tracemalloc.start()
            residual(x, 10_000.0, p, c)
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            print(f"{name:>9} {n:>9} {best:>9.3f} {peak / 1e6:>10.1f} {peak / n:>9.0f} "
                  f"{info.samples_per_cycle:>6} {info.n_complete_cycles:>7}")
    if args.joint:
        for n in (300_000, 1_200_000):
            x, p = sweep(n)
            for mode in ("cascade", "joint"):
                t = time.perf_counter()
                _, info = residual_joint(x, 10_000.0, p, [1.0, MESH2], mode=mode,
                                             return_info=True)
                print(f"{mode:>9} {n:>9} {time.perf_counter() - t:>9.3f} "
                      f"passes={info.iterations}")


if __name__ == "__main__":
    main()
