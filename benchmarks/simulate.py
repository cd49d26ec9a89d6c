"""Benchmark `gbpipe.simulate.lsim.lsim` against `control.forced_response`.

Runs both on the same closed-loop bench model and the same 1e6-sample random input and
prints a table with wall times, the speed ratio and the largest relative output difference.

Like is compared with like: `control.forced_response` on a *continuous* system interpolates
the input linearly between samples (first-order hold, see its source in
``control/timeresp.py``), whereas `lsim` holds each sample (zero-order hold). The reference
is therefore ``control.forced_response(sys.sample(dt, "zoh"), inputs=u.T)``, which calls
``scipy.signal.dlsim`` on the exact ZOH discretisation (a Python loop over samples).

Usage: ``OMP_NUM_THREADS=1 python benchmarks/simulate.py [n_samples]``
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import control
import numpy as np

from gbpipe.simulate.lsim import lsim

FS = 5000.0  # Hz


def standin_bench(seed: int = 7) -> control.StateSpace:
    """Stand-in for the closed-loop test bench: 22-inertia chain + 2 PI loops.

    States: 21 twists [rad], 22 speeds [rad/s], 2 PI integrators, 1 absolute HSS angle
    [rad] (46 states). Inputs (6): speed set point [rad/s], load torque set point [N·m],
    4 disturbance torques [N·m]. Outputs (7): 3 speeds, 3 shaft torques, HSS angle.
    Torsional modes roughly 10-400 Hz with 0.1-4 % damping; the angle adds an eigenvalue
    at 0 (lam = 1 after discretisation).
    """
    rng = np.random.default_rng(seed)
    nb = 22
    inertia = np.exp(rng.uniform(np.log(0.05), np.log(2.0), nb))
    inertia[0], inertia[-1] = 20.0, 15.0  # drive and load motors
    k = np.exp(rng.uniform(np.log(4e4), np.log(3e5), nb - 1))
    # Twist incidence: twist_i = theta_i - theta_{i+1}
    e = np.zeros((nb - 1, nb))
    e[np.arange(nb - 1), np.arange(nb - 1)] = 1.0
    e[np.arange(nb - 1), np.arange(1, nb)] = -1.0
    kmat = e.T @ np.diag(k) @ e
    beta = 2 * 0.01 / (2 * np.pi * 100.0)  # stiffness-proportional: 1 % at 100 Hz
    minv = np.diag(1.0 / inertia)
    ns = (nb - 1) + nb + 2 + 1
    a = np.zeros((ns, ns))
    it, iw, ipi1, ipi2, ith = 0, nb - 1, 2 * nb - 1, 2 * nb, 2 * nb + 1
    a[it:iw, iw:ipi1] = e  # d twist/dt = E omega
    a[iw:ipi1, it:iw] = -minv @ e.T @ np.diag(k)  # spring torques
    a[iw:ipi1, iw:ipi1] = -minv @ (beta * kmat)  # damping
    j_tot = inertia.sum()
    kp1, ki1 = j_tot * 2 * np.pi * 2.0, j_tot * (2 * np.pi * 2.0) ** 2 / 4
    kp2, ki2 = 0.0, 2 * np.pi * 1.0 * 0.2  # slow integral torque loop
    # Drive motor: T1 = kp1 (w_ref - w0) + ki1 * int(w_ref - w0)
    a[iw + 0, iw + 0] -= kp1 / inertia[0]
    a[iw + 0, ipi1] += ki1 / inertia[0]
    a[ipi1, iw + 0] = -1.0
    # Load motor torque loop on the last shaft torque: T2 = -(T_ref + kp2 e + ki2 int e),
    # e = T_ref - k_last * twist_last (load motor brakes the chain)
    a[iw + nb - 1, it + nb - 2] += kp2 * k[-1] / inertia[-1]
    a[iw + nb - 1, ipi2] -= ki2 / inertia[-1]
    a[ipi2, it + nb - 2] = -k[-1]
    a[ith, iw + 12] = 1.0  # HSS angle
    b = np.zeros((ns, 6))
    b[iw + 0, 0] = kp1 / inertia[0]
    b[ipi1, 0] = 1.0
    b[iw + nb - 1, 1] = -(1 + kp2) / inertia[-1]
    b[ipi2, 1] = 1.0
    for col, body in zip(range(2, 6), (4, 9, 12, 17), strict=True):
        b[iw + body, col] = 1.0 / inertia[body]
    c = np.zeros((7, ns))
    for row, body in enumerate((0, 12, nb - 1)):
        c[row, iw + body] = 1.0
    for row, spring in zip((3, 4, 5), (0, 10, nb - 2), strict=True):
        c[row, it + spring] = k[spring]
    c[6, ith] = 1.0
    return control.ss(a, b, c, np.zeros((7, 6)))


def bench_systems() -> list[tuple[control.StateSpace, str]]:
    """The real bench model if `gbpipe.model.bench` exists, and the 46-state stand-in."""
    standin = (standin_bench(), "stand-in 22-inertia chain + 2 PI loops")
    try:
        import gbpipe.config
        import gbpipe.model

        root = Path(__file__).resolve().parents[1]
        cfg = gbpipe.config.load(root / "config" / "config.yaml")
        return [(gbpipe.model.bench(cfg), "gbpipe.model.bench(config/config.yaml)"), standin]
    except (ImportError, AttributeError) as exc:
        print(f"note: real bench model not available ({exc!r}); using the stand-in only")
        return [standin]


def main(n_samples: int = 1_000_000) -> None:
    for sysc, label in bench_systems():
        run_case(sysc, label, n_samples)
        print()


def run_case(sysc: control.StateSpace, label: str, n_samples: int) -> None:
    dt = 1.0 / FS
    rng = np.random.default_rng(0)
    u = rng.standard_normal((n_samples, sysc.ninputs)) * 100.0
    u[:, 0] = 100.0 + 0.1 * u[:, 0]  # speed set point around 100 rad/s
    print(
        f"system: {label}; {sysc.nstates} states, {sysc.ninputs} inputs, "
        f"{sysc.noutputs} outputs; fs = {FS:g} Hz; {n_samples} samples"
    )
    rows = []

    t0 = time.perf_counter()
    sysd = sysc.sample(dt, "zoh")
    ref = control.forced_response(sysd, inputs=u.T).outputs.T
    t_ref = time.perf_counter() - t0
    rows.append(("control.forced_response(sys.sample(dt,'zoh'))", t_ref, None))

    scale = np.abs(ref).max(axis=0)
    lsim(sysc, u[:1000], dt)  # warm-up (imports, BLAS initialisation)
    for method in ("auto", "modal", "block"):
        times = []
        for _ in range(3):  # best of 3: the machine is shared
            t0 = time.perf_counter()
            y, _ = lsim(sysc, u, dt, method=method)
            times.append(time.perf_counter() - t0)
        t = min(times)
        rel = float(np.max(np.abs(y - ref).max(axis=0) / scale))
        rows.append((f"gbpipe lsim(method='{method}')", t, rel))

    print(f"{'method':<48} {'time [s]':>9} {'speed-up':>9} {'max rel diff':>13}")
    for name, t, rel in rows:
        rel_s = "-" if rel is None else f"{rel:.2e}"
        print(f"{name:<48} {t:9.3f} {t_ref / t:9.1f} {rel_s:>13}")
    print(
        "times: reference 1 run (includes sys.sample), lsim best of 3 (includes expm and eig); "
        "max rel diff = max over outputs of max|y - y_ref| / max|y_ref|"
    )


if __name__ == "__main__":
    main(int(float(sys.argv[1])) if len(sys.argv) > 1 else 1_000_000)
