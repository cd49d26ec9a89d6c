"""Why the Vold-Kalman backfitting diverges where orders crowd (docs/removal.md,
"Vold-Kalman orders within a bandwidth"): dense copies of the operators of a short
record, the eigenvalues of one order's update and the spectral radius of the passes.

An order's update ``v -> 2 Re(exp(-1j phi) S (exp(1j phi) v))``, ``S = (I + w D^T D)^-1``
(:class:`gbpipe.harmonics.vkf.EnvelopeFilter`'s system, dense), is symmetric; its largest
eigenvalues and where their eigenvectors live (the record's first and last second) are
printed, then the spectral radius of one backfitting pass over the mean and two orders
(power iteration on the error, which a pass maps as Gauss-Seidel does), for two positions
of the first order and several distances of the second. A radius above 1 diverges.

Usage: ``PYTHONPATH=$PWD/src python benchmarks/vkf_divergence.py [--fs 100] [--seconds 15]``
"""

from __future__ import annotations

import argparse

import numpy as np

from gbpipe.harmonics.vkf import structural_weight


def smoother(n: int, fs: float, bandwidth: float = 1.0) -> np.ndarray:
    """Dense ``S = (I + w D2^T D2)^-1`` of the 1 Hz envelope filter (second differences)."""
    d2 = np.diff(np.eye(n), 2, axis=0)
    return np.linalg.inv(np.eye(n) + structural_weight(bandwidth, fs, 2) * d2.T @ d2)


def order_update(s: np.ndarray, f: float, fs: float) -> np.ndarray:
    """Dense real operator of one order's update at ``f`` Hz (constant speed)."""
    e = np.exp(2j * np.pi * f * np.arange(s.shape[0]) / fs)
    return 2.0 * (np.conj(e)[:, None] * s * e[None, :]).real


def pass_radius(ops: list[np.ndarray], iterations: int = 60) -> float:
    """Spectral radius of a backfitting pass's error map, by power iteration."""
    rng = np.random.default_rng(0)
    err = [rng.standard_normal(ops[0].shape[0]) for _ in ops]
    growth = 0.0
    for _ in range(iterations):
        for k, op in enumerate(ops):
            err[k] = -op @ sum(e for j, e in enumerate(err) if j != k)
        growth = float(np.sqrt(sum(float(e @ e) for e in err)))
        err = [e / growth for e in err]
    return growth


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fs", type=float, default=100.0)
    ap.add_argument("--seconds", type=float, default=15.0)
    args = ap.parse_args()
    n, fs = int(args.seconds * args.fs), args.fs
    s = smoother(n, fs)
    edge = int(fs)  # samples in the first and last second
    vals, vecs = np.linalg.eigh(order_update(s, 10.0 / 3.0, fs))
    print(f"one order at 3.33 Hz, 1 Hz bandwidth, {args.seconds:g} s at {fs:g} Hz:")
    for i in range(1, 5):
        v = vecs[:, -i]
        print(f"  eigenvalue {vals[-i]:.4f}: energy in the first / last second "
              f"{v[:edge] @ v[:edge]:.3f} / {v[-edge:] @ v[-edge:]:.3f}")
    distances = [0.2, 0.5, 1.0, 1.5, 2.0, 3.0]
    print("spectral radius of a pass (the mean and two orders); distance [Hz]:",
          "  ".join(f"{d:5.1f}" for d in distances))
    for first in (20.0, 10.0 / 3.0):
        radii = [pass_radius([s, order_update(s, first, fs), order_update(s, first - d, fs)])
                 for d in distances]
        print(f"  first order at {first:5.2f} Hz:", "  ".join(f"{r:5.3f}" for r in radii))


if __name__ == "__main__":
    main()
