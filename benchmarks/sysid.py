"""Benchmark: gbpipe.sysid against SIPPY (sippy-unipi) and nfoursid on the same data.

Open loop: 4th-order SISO plant with two lightly damped resonances (0.1 fs, zeta 0.02;
0.3 fs, zeta 0.01; zeros at +-0.5), white unit input, white output noise at 20 dB SNR, N = 1e4,
1e5, 1e6. Every method runs in a fresh subprocess, so its peak memory is measured alone:
``peak MB`` is the growth of the resident set (VmHWM after the call minus VmRSS before, with the
high-water mark reset just before the call). ``time s`` is wall time, ``CPU s`` the process's
CPU time (less sensitive to other jobs on a shared machine). ``FRF err`` is the maximum over
500 frequencies in (0, fs/2) of ``|G_est - G| / |G|``. A last table gives the speed-up of each
gbpipe method over each SIPPY method at the same N (wall and CPU time).

Closed loop: the same plant under a PI controller (kp 0.3, ki 0.05) with a white reference and
coloured noise (innovation model sharing the plant poles, predictor poles at radius 0.7) at
20 dB SNR, N = 1e5; fit % of the simulated model against the noise-free plant output.

Peers come from requirements-bench.txt (``pip install -r requirements-bench.txt``). A peer is
run at the next N only when its time at the previous N, scaled linearly, stays under
``--budget`` seconds and its memory estimate under 8 GB; otherwise it prints
``skipped (est. ...)``.

The plant, the closed-loop data and the reference simulator are the test fixtures of
``tests/sysid/sysid_plants.py`` (one implementation; that folder is put on ``sys.path``).

Identify-stage size (``--stage-size``): one fit of each method at the size the identify stage
uses (N = 6e4 at 1 kHz, past 100, future 50, order 24), SISO and 2x2, on an order-24 modal
plant whose input and noisy output are low-passed at 0.8 x Nyquist by an FIR with 80 dB and
120 dB stop band (``tests/sysid/sysid_plants.py``: ``stage_data``), best of 3 wall times and
the median relative FRF error against the truth over 1-380 Hz; then the validation step (a
40 s record in 2 s segments, each from its least-squares initial state): ``estimate_x0`` +
``simulate`` per segment against the batched ``SubspaceModel.simulate_segments``.

Each method runs ``--repeats`` times (default 3), each time in a fresh process; the
fastest run's times are reported with the largest peak memory of the runs.

Usage: ``OMP_NUM_THREADS=1 python benchmarks/sysid.py [--budget 240] [--sizes 1e4 1e5 1e6]``;
quick check: ``--sizes 1e4 --methods "gbpipe pbsid" --closed-loop 2e4``; stage size:
``--stage-size``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "sysid"))

from sysid_plants import closed_loop_data, simulate, stage_data, two_mode_plant  # noqa: E402

from gbpipe import sysid  # noqa: E402

F_GRID = np.linspace(0.001, 0.499, 500)  # Hz, dt = 1 s
HORIZON = 10  # MOESP/N4SID future (= past) window; also SIPPY SS_f and nfoursid block rows
PBSID_PAST, PBSID_FUTURE = 50, 10


def plant():
    """The benchmark plant (discrete time, dt = 1): A, B, C, D."""
    return two_mode_plant()


def frf(A, B, C, D, f):
    z = np.exp(2j * np.pi * f)
    n = A.shape[0]
    g = np.linalg.solve(z[:, None, None] * np.eye(n) - A, np.broadcast_to(B, (f.size, n, 1)))
    return (C @ g + D)[:, 0, 0]


def make_open_loop(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((n, 1))
    y0 = simulate(*plant(), u)
    y = y0 + 0.1 * y0.std() * rng.standard_normal((n, 1))  # 20 dB SNR
    return u, y


def make_closed_loop(n: int, seed: int = 1, snr_db: float = 20.0):
    u, y, y0, _, snr = closed_loop_data(n, snr_db, seed)
    return u, y, y0, snr


def _gbpipe(name):
    def run(u, y):
        if name == "pbsid":
            m = sysid.pbsid(u, y, 4, past=PBSID_PAST, future=PBSID_FUTURE)
        else:
            m = getattr(sysid, name)(u, y, 4, horizon=HORIZON)
        return m.A, m.B, m.C, m.D
    return run


def _sippy(name):
    def run(u, y):
        from sippy_unipi import system_identification  # optional dependency (benchmark peer)

        kw = {"SS_fixed_order": 4, "SS_f": HORIZON, "tsample": 1.0}
        if name == "PARSIM-K":
            kw["SS_p"] = HORIZON
        with contextlib.redirect_stdout(io.StringIO()):
            m = system_identification(y[:, 0], u[:, 0], name, **kw)
        return np.asarray(m.A), np.asarray(m.B), np.asarray(m.C), np.asarray(m.D)
    return run


def _nfoursid(u, y):
    import pandas as pd  # optional dependency (nfoursid's API)
    from nfoursid.nfoursid import NFourSID  # optional dependency (benchmark peer)

    df = pd.DataFrame({"u": u[:, 0], "y": y[:, 0]})
    nf = NFourSID(df, output_columns=["y"], input_columns=["u"], num_block_rows=HORIZON)
    nf.subspace_identification()
    ss, _ = nf.system_identification(rank=4)
    return ss.a, ss.b, ss.c, ss.d


METHODS = {
    "gbpipe pbsid": _gbpipe("pbsid"),
    "gbpipe moesp": _gbpipe("moesp"),
    "gbpipe n4sid": _gbpipe("n4sid"),
    "SIPPY N4SID": _sippy("N4SID"),
    "SIPPY MOESP": _sippy("MOESP"),
    "SIPPY PARSIM-K": _sippy("PARSIM-K"),
    "nfoursid": _nfoursid,
}
# Peak memory a peer needs beyond O(N) (bytes, as a function of N): nfoursid takes a full
# SVD of a (rows x N) matrix, whose right factor alone is N x N doubles.
MEM_MODEL = {"nfoursid": lambda n: 8.0 * n * n}


def _rss(field: str) -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(field):
                return float(line.split()[1]) / 1024.0  # MB
    return float("nan")


def worker(method: str, path: str) -> None:
    data = np.load(path)
    u, y = data["u"], data["y"]
    fn = METHODS[method]
    # Import the method's modules before measuring (import cost is not identification).
    try:
        fn(u[:2000], y[:2000])
    except Exception:  # noqa: BLE001 - warm-up only
        pass
    base = _rss("VmRSS")
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")  # reset the peak-RSS counter (Linux >= 4.0)
    except OSError:
        pass
    t0, c0 = time.perf_counter(), time.process_time()
    A, B, C, D = fn(u, y)
    elapsed, cpu = time.perf_counter() - t0, time.process_time() - c0
    peak = _rss("VmHWM") - base
    g = frf(*plant(), F_GRID)
    err = float(np.max(np.abs(frf(A, B, C, D, F_GRID) - g) / np.abs(g)))
    print(json.dumps({"time": elapsed, "cpu": cpu, "peak_mb": peak, "total_mb": _rss("VmHWM"),
                      "err": err}))


def run_worker(method: str, path: Path, timeout: float) -> dict:
    cmd = [sys.executable, __file__, "--worker", method, str(path)]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return {"error": f"timeout > {timeout:.0f} s"}
    lines = [ln for ln in out.stdout.splitlines() if ln.startswith("{")]
    if out.returncode != 0 or not lines:
        tail = (out.stderr.strip().splitlines() or ["?"])[-1]
        return {"error": f"failed: {tail[:60]}"}
    return json.loads(lines[-1])


def _fastest(runs: list[dict]) -> dict:
    """The run with the least wall time, with the largest peak memory of all runs (each
    run is a cold call in a fresh process: nothing is remembered between them)."""
    best = dict(min(runs, key=lambda r: r["time"]))
    best["peak_mb"] = max(r["peak_mb"] for r in runs)
    return best


def closed_loop_table(n: int) -> None:
    u, y, y0, snr = make_closed_loop(n)
    print(f"\nClosed loop, PI controller, white reference, N = {n:.0e}, SNR = {snr:.1f} dB "
          "(coloured noise); fit % against the noise-free output")
    print(f"{'method':<16}{'time s':>9}{'fit %':>9}{'FRF err':>10}")
    g = frf(*plant(), F_GRID)
    for name, call in (
        ("gbpipe pbsid", lambda: sysid.pbsid(u, y, 4, past=20)),
        ("gbpipe moesp", lambda: sysid.moesp(u, y, 4, horizon=HORIZON)),
        ("gbpipe n4sid", lambda: sysid.n4sid(u, y, 4, horizon=HORIZON)),
    ):
        t0 = time.perf_counter()
        m = call()
        el = time.perf_counter() - t0
        yh = m.simulate(u)[:, 0]
        fit = 100 * (1 - np.linalg.norm(y0 - yh) / np.linalg.norm(y0 - y0.mean()))
        err = np.max(np.abs(frf(m.A, m.B, m.C, m.D, F_GRID) - g) / np.abs(g))
        print(f"{name:<16}{el:>9.3f}{fit:>9.2f}{err:>10.4f}")


def speedup_table(results: dict[tuple[str, int], dict]) -> None:
    """Time of each SIPPY method over that of each gbpipe method, same N (wall and CPU)."""
    peers = [p for p in ("SIPPY N4SID", "SIPPY MOESP", "SIPPY PARSIM-K")
             if any(key[0] == p for key in results)]
    if not peers:
        return
    print("\nSpeed-up: SIPPY time / gbpipe time, wall (CPU)")
    print(f"{'method':<16}{'N':>9}" + "".join(f"{p:>22}" for p in peers))
    for (method, n), res in sorted(results.items(), key=lambda kv: (kv[0][1], kv[0][0])):
        if not method.startswith("gbpipe"):
            continue
        cells = []
        for p in peers:
            ref = results.get((p, n))
            cells.append("-" if ref is None else
                         f"{ref['time'] / res['time']:.0f}x ({ref['cpu'] / res['cpu']:.0f}x)")
        print(f"{method:<16}{n:>9.0e}" + "".join(f"{c:>22}" for c in cells))


def _best_of(fn, repeats: int = 3):
    """Result of ``fn()`` and its best wall time over ``repeats`` calls [s]."""
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


def stage_size_table() -> None:
    """Timings at the identify stage's problem size (module docstring)."""
    dt, f = 1e-3, np.linspace(1.0, 380.0, 300)
    fits = {
        "pbsid": lambda u, y: sysid.pbsid(u, y, 24, 100, 50, dt=dt),
        "moesp": lambda u, y: sysid.moesp(u, y, 24, 50, dt, past=100),
        "n4sid": lambda u, y: sysid.n4sid(u, y, 24, 50, dt, past=100),
    }
    print("\nIdentify-stage size: N = 6e4, past 100, future 50, order 24 (best of 3)")
    print(f"{'case':<16}{'stop dB':>8}{'method':>8}{'time ms':>10}{'FRF err':>10}")
    for (m, l_), stop in (((1, 1), 80.0), ((2, 2), 80.0), ((1, 1), 120.0), ((2, 2), 120.0)):
        u, y, (A, B, C, D) = stage_data(60_000, m, l_, seed=0, stop_db=stop)
        z = np.exp(2j * np.pi * f * dt)
        g = C @ np.linalg.solve(z[:, None, None] * np.eye(A.shape[0]) - A,
                                np.broadcast_to(B, (f.size, *B.shape)))
        for name, fit in fits.items():
            model, el = _best_of(lambda fit=fit, u=u, y=y: fit(u, y))
            err = float(np.median(np.abs(model.frf(f) - g) / np.abs(g)))
            print(f"{f'{m}x{l_}':<16}{stop:>8.0f}{name:>8}{1e3 * el:>10.1f}{err:>10.4f}",
                  flush=True)
    u, y, _ = stage_data(40_000, 2, 2, seed=1)
    model = sysid.moesp(u, y, 24, 50, dt, past=100)
    seg = 2000

    def per_segment():
        for a in range(0, len(u), seg):
            model.simulate(u[a:a + seg], model.estimate_x0(u[a:a + seg], y[a:a + seg]))

    _, t_loop = _best_of(per_segment)
    print(f"validation, 2x2, 40 s in 2 s segments: estimate_x0 + simulate per segment "
          f"{1e3 * t_loop:.1f} ms", end="")
    if hasattr(model, "simulate_segments"):  # absent before the batched version
        _, t_batch = _best_of(lambda: model.simulate_segments(u, y, seg))
        print(f", simulate_segments {1e3 * t_batch:.1f} ms", end="")
    print()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worker", nargs=2, metavar=("METHOD", "DATA"), help=argparse.SUPPRESS)
    ap.add_argument("--sizes", nargs="+", type=float, default=[1e4, 1e5, 1e6])
    ap.add_argument("--budget", type=float, default=240.0,
                    help="largest estimated run time (s) for which a peer is still run")
    ap.add_argument("--methods", nargs="+", default=list(METHODS))
    ap.add_argument("--repeats", type=int, default=3,
                    help="fresh processes per method and N; the fastest is reported (a "
                         "single call of gbpipe at N = 1e6 takes 25-75 ms, and scheduling "
                         "noise on a shared machine is of that size)")
    ap.add_argument("--closed-loop", type=float, default=1e5,
                    help="samples of the closed-loop comparison (0: skip it)")
    ap.add_argument("--stage-size", action="store_true",
                    help="only the identify-stage-size timings (module docstring)")
    args = ap.parse_args()
    if args.worker:
        worker(*args.worker)
        return
    if args.stage_size:
        stage_size_table()
        return
    print(f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}, "
          f"{os.cpu_count()} CPUs; open loop, 20 dB white output noise")
    print(f"{'method':<16}{'N':>9}{'time s':>10}{'CPU s':>10}{'peak MB':>10}{'FRF err':>10}")
    last: dict[str, tuple[int, float]] = {}
    results: dict[tuple[str, int], dict] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in (int(s) for s in args.sizes):
            u, y = make_open_loop(n)
            path = Path(tmp) / f"data_{n}.npz"
            np.savez(path, u=u, y=y)
            for method in args.methods:
                est_mem = MEM_MODEL.get(method, lambda _n: 0.0)(n)
                est_t = None
                if method in last:
                    n0, t0 = last[method]
                    est_t = t0 * n / n0
                if est_mem > 8e9:
                    row = f"skipped (est. {est_mem / 1e9:.0f} GB: N x N SVD factor)"
                elif est_t is not None and est_t > args.budget and not method.startswith("gb"):
                    row = f"skipped (est. {est_t:.0f} s)"
                else:
                    runs = [run_worker(method, path, timeout=max(3 * args.budget, 60))
                            for _ in range(args.repeats)]
                    res = next((r for r in runs if "error" in r), None) or _fastest(runs)
                    if "error" in res:
                        row = res["error"]
                    else:
                        last[method] = (n, res["time"])
                        results[(method, n)] = res
                        row = (f"{res['time']:>10.3f}{res['cpu']:>10.3f}{res['peak_mb']:>10.1f}"
                               f"{res['err']:>10.4f}")
                print(f"{method:<16}{n:>9.0e}{row if row[0] == ' ' else '  ' + row}",
                      flush=True)
    speedup_table(results)
    if args.closed_loop:
        closed_loop_table(int(args.closed_loop))


if __name__ == "__main__":
    main()
