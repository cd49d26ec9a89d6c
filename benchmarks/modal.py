"""Benchmark gbpipe's stabilization modes (subspace and LSCF) against pyOMA2 and sdypy-EMA.

Two records, every tool on the same data in one process:

* ``bench``: the measured-like simulated bench record ``ms_torque_square`` of
  ``config/config.yaml`` (``gbpipe.simulate.test(..., measured_like=True)``: closed loop,
  harmonics, sensor noise), high-passed at 2 Hz and decimated 5 x to 1 kHz; inputs the
  two motor torques, outputs the two HSS speeds. Reference: the modes of gbpipe's
  closed-loop bench model.
* ``chain``: a model gbpipe did not build, an opentorsion assembly (7 disks on two shafts
  joined by a 1:3 gear pair, tied to the ground at the first disk, 2 % modal damping),
  simulated with ``scipy.signal.dlsim`` (zero-order hold, white-noise torque on the first
  disk, four speeds out with 2 % white measurement noise). Reference: opentorsion's
  ``modal_analysis``.

Tools: gbpipe ``stabilization_diagram`` (PBSID on the closed-loop bench, MOESP on the open-loop
chain) and ``lscf_stabilization`` on the H1 FRF (``gbpipe.sysid.welch_frf``); pyOMA2 SSI-cov
on the outputs with its stabilization and hierarchical clustering (``quick="hier_avg"``);
sdypy-EMA's LSCF on the same FRF. sdypy-EMA picks poles from its stability chart by hand (a
GUI) or near given frequencies: it is given gbpipe's subspace frequencies, so its column
tests whether its stable poles agree there, not whether it finds modes alone.

Printed per tool: frequencies [Hz], damping ratios [1], CPU and wall time [s] (the machine
is shared: CPU time is the comparable figure), peak traced memory [MiB] (``tracemalloc``, in
a second, untimed run), and each gbpipe mode's frequency over the nearest peer mode's.

Usage: ``OMP_NUM_THREADS=1 python benchmarks/modal.py`` (peers: ``requirements-bench.txt``).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path

import numpy as np
import scipy.signal
from modal_peers import measured, pyoma2_ssicov, sdypy_lscf

from gbpipe import simulate
from gbpipe.config import load
from gbpipe.lti.modal import modes
from gbpipe.model import bench_ss
from gbpipe.sysid import lscf_stabilization, stabilization_diagram, welch_frf

ROOT = Path(__file__).resolve().parents[1]
ORDERS = range(2, 61, 2)  # state dimensions (subspace), SSI-cov orders
LSCF_POLES = 120  # poles of the highest LSCF order (polynomial order x inputs)


def bench_record() -> tuple[np.ndarray, np.ndarray, float, np.ndarray, str]:
    """Inputs (N, 2) [N·m], outputs (N, 2) [rad/s], dt [s], reference modes [Hz], method."""
    cfg = load(ROOT / "config" / "config.yaml")
    ds = simulate.test(cfg, "ms_torque", "square", measured_like=True)
    fs = float(cfg["campaign"]["sample_rate"])
    u = np.column_stack([ds[f"motor_torque_{s}_measured"].values
                         for s in ("driver", "driven")])
    y = np.column_stack([ds[f"speed_{s}_hss_measured"].values for s in ("gb2", "gb1")])
    # The set-point steps and ramps are no resonance: 2 Hz high-pass (zero phase), then
    # 5 x decimation to 1 kHz (the modes of interest lie below 400 Hz).
    sos = scipy.signal.butter(4, 2.0, "highpass", fs=fs, output="sos")
    q = 5
    u = scipy.signal.decimate(scipy.signal.sosfiltfilt(sos, u, axis=0), q, axis=0)
    y = scipy.signal.decimate(scipy.signal.sosfiltfilt(sos, y, axis=0), q, axis=0)
    ss = bench_ss(cfg, closed=True)
    f_ref, _ = modes(np.asarray(ss.A))
    return u, y, q / fs, f_ref[f_ref < 0.4 * fs / q], "pbsid"


def chain_record(seed: int = 3) -> tuple[np.ndarray, np.ndarray, float, np.ndarray, str]:
    """An opentorsion geared chain: inputs (N, 1) [N·m], outputs (N, 4) [rad/s]."""
    import opentorsion as ot

    shafts = [ot.Shaft(i, i + 1, k=k) for i, k in zip(range(3), (4e5, 3e5, 5e5), strict=True)]
    shafts += [ot.Shaft(i, i + 1, k=k) for i, k in zip(range(4, 7), (2e5, 1e5, 1.5e5),
                                                       strict=True)]
    disks = [ot.Disk(0, 2.0, k=2e5), ot.Disk(1, 1.5), ot.Disk(2, 1.0), ot.Disk(5, 3.0),
             ot.Disk(6, 2.5), ot.Disk(7, 4.0)]
    g1 = ot.Gear(3, 0.5, 1.0)
    gears = [g1, ot.Gear(4, 1.2, 3.0, parent=g1)]
    asm = ot.Assembly(shafts, disk_elements=disks, gear_elements=gears)
    m, k = asm.M, asm.K
    c = asm.C_modal(m, k, xi=0.02)
    wn, _, _ = asm.modal_analysis(C=c)
    f_ref = np.unique(np.round(wn / (2 * np.pi), 9))
    f_ref = f_ref[f_ref > 1e-6]
    n = m.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(m, k), -np.linalg.solve(m, c)]])
    b = np.zeros((2 * n, 1))
    b[n:, 0] = np.linalg.solve(m, np.eye(n)[:, 0])
    cm = np.eye(2 * n)[n + np.array([0, 2, 4, n - 1])]
    dt = 1.0 / (8.0 * f_ref.max())
    ad, bd, cd, dd, _ = scipy.signal.cont2discrete((a, b, cm, np.zeros((4, 1))), dt)
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((40000, 1))
    _, y, _ = scipy.signal.dlsim((ad, bd, cd, dd, dt), u)
    y = y + 0.02 * y.std(axis=0) * rng.standard_normal(y.shape)
    return u, y, dt, f_ref, "moesp"


def gbpipe_subspace(u, y, dt, method):
    kw = {"past": 200, "future": 31} if method == "pbsid" else {"horizon": 31, "past": 60}
    st = stabilization_diagram(u, y, dt, ORDERS, method, **kw)
    return [(m.frequency_hz, m.damping) for m in st.clusters]


def gbpipe_lscf(frf, dt):
    # Default weights (each output by its RMS). The inverse confidence radius, PolyMAX's
    # inverse standard deviation, lost the four lowest chain modes: the lines far above
    # them, of tiny radius, took the fit.
    top = LSCF_POLES // frf.frf.shape[2]
    st = lscf_stabilization(frf.frequency, frf.frf, range(2, top + 1, 2), dt)
    return [(m.frequency_hz, m.damping) for m in st.clusters]


def report(name: str, record: Callable) -> None:
    u, y, dt, f_ref, method = record()
    frf = welch_frf(u, y, 1.0 / dt, nperseg=8192)
    frf = frf._replace(frequency=frf.frequency[1:], frf=frf.frf[1:])  # no DC line
    print(f"\n== {name}: {u.shape[0]} samples at {1 / dt:.1f} Hz, {u.shape[1]} input(s), "
          f"{y.shape[1]} output(s); reference modes [Hz]: {np.round(f_ref, 2).tolist()}")
    results = {}
    results["gbpipe " + method] = measured(lambda: gbpipe_subspace(u, y, dt, method))
    results["gbpipe lscf"] = measured(lambda: gbpipe_lscf(frf, dt))
    results["pyOMA2 ssi-cov"] = measured(lambda: pyoma2_ssicov(y, dt, max(ORDERS)))
    approx = [f for f, _ in results["gbpipe " + method][0]]
    results["sdypy-EMA lscf"] = measured(lambda: sdypy_lscf(frf, approx, LSCF_POLES))
    for tool, (found, cpu, wall, peak) in results.items():
        print(f"{tool:16s} cpu {cpu:7.2f} s  wall {wall:7.2f} s  peak {peak:8.1f} MiB  "
              f"{len(found)} modes")
        print("   f [Hz] " + " ".join(f"{f:8.2f}" for f, _ in found))
        print("   zeta   " + " ".join(f"{z:8.4f}" for _, z in found))
    # Ratio to the nearest peer mode; "-" when the peer has none within 5 % (not found).
    for ours in ("gbpipe " + method, "gbpipe lscf"):
        for peer in ("pyOMA2 ssi-cov", "sdypy-EMA lscf"):
            fp = np.array([f for f, _ in results[peer][0]] or [np.inf])
            ratios = [f / fp[np.argmin(np.abs(fp - f))] for f, _ in results[ours][0]]
            print(f"{ours} / {peer}: " + " ".join(
                f"{r:.4f}" if abs(r - 1) < 0.05 else "-" for r in ratios))


if __name__ == "__main__":
    logging.disable(logging.WARNING)  # pyOMA2 logs every step
    report("chain (opentorsion)", chain_record)
    report("bench (gbpipe simulate, measured-like)", bench_record)
