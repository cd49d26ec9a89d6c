"""Torsional models assembled by hand, independently of gbpipe.model: the mass and
stiffness matrices of a gearbox whose housing sits on its mounts, and of the
back-to-back bench, written out from the kinematics; their undamped frequencies from
``K v = ω² M v`` (scipy). For configs whose stage inertias are lumped on each stage's
input member (the form of config/config.yaml and the example gearbox).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from scipy.linalg import block_diag, eigh


def gearbox_matrices(gb: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Mass [kg·m²] and stiffness [N·m/rad] matrices of one gearbox on elastic mounts.

    Coordinates: housing angle h, each stage's input member (carrier or wheel, which
    carries the stage's lumped inertia), the HSS flange. The gears are rigid relative to
    the housing (Willis): a planetary sun turns at ``(1 + Zr/Zs)·a − (Zr/Zs)·h``, a
    parallel pinion at ``h + (Zw/Zp)·(a − h)``. Shaft i twists between stage i's output
    member and the next input member (or the flange); the mount twists by h.
    """
    if not all(isinstance(j, float) for j in gb["inertia"]):
        raise ValueError("hand model: stage inertias must be lumped numbers")
    stages, n = gb["stages"], len(gb["stages"])
    M = np.diag([float(gb["housing"]["inertia"]), *gb["inertia"]])
    K = np.zeros_like(M)
    for i, st in enumerate(stages):
        g = np.zeros(n + 2)               # twist of shaft i = g · q
        g[i + 2] = 1.0
        if st["type"] == "planetary":
            rs = st["ring"] / st["sun"]
            g[i + 1], g[0] = -(1 + rs), rs
        else:
            r = st["wheel"] / st["pinion"]
            g[i + 1], g[0] = -r, -(1 - r)
        K += gb["stiffness"][i] * np.outer(g, g)
    K[0, 0] += gb["housing"]["stiffness"]
    return M, K


def frequencies(M: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Undamped natural frequencies [Hz] of ``K v = ω² M v``, rigid-body modes left out."""
    w2 = eigh(K, M, eigvals_only=True)
    return np.sqrt(w2[w2 > 1e-6 * w2.max()]) / (2 * np.pi)


def bench_matrices(cfg: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Mass and stiffness matrices of the bench: driver motor, GB2, GB1, driven motor.

    The driver coupling joins the driver motor to GB2's flange, the LSS shaft the two
    first-stage input members, the driven coupling GB1's flange to the driven motor.
    """
    gb, bench = cfg["gearbox"], cfg["bench"]
    Mg, Kg = gearbox_matrices(gb)
    m = Mg.shape[0]
    M = block_diag([[bench["motor_inertia"]["driver"]]], Mg, Mg,
                   [[bench["motor_inertia"]["driven"]]])
    K = block_diag([[0.0]], Kg, Kg, [[0.0]])
    gb2, gb1 = 1, 1 + m                               # first index of each gearbox
    driven = 1 + 2 * m
    links = [(0, gb2 + m - 1, bench["coupling"]["stiffness"]),          # driver - GB2 flange
             (gb2 + 1, gb1 + 1, bench["lss_shaft"]["stiffness"]),        # stage-1 inputs
             (gb1 + m - 1, driven, bench["coupling"]["stiffness"])]      # GB1 flange - driven
    for a, b, k in links:
        g = np.zeros(M.shape[0])
        g[a], g[b] = 1.0, -1.0
        K += k * np.outer(g, g)
    return M, K
