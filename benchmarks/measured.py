"""Streaming benchmark of :func:`gbpipe.measured.read`: MB/s and peak RSS for 1x, 2x and
4x a record length, for TDMS and CSV.

Each read runs in a fresh interpreter so its peak RSS (``ru_maxrss``) is its own; the
"imports" row is the same interpreter importing gbpipe.measured and reading nothing.
Time and the RSS above the import baseline should both grow linearly with the length
(one float64 copy of the signals, plus the output Dataset).

Usage: ``OMP_NUM_THREADS=1 python benchmarks/measured.py [--samples 250000] [--fs 10000]``
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from nptdms import ChannelObject, TdmsWriter

CHANNELS = ("torque_a", "torque_b", "speed_a", "speed_b")
BLOCK = 100_000

_CHILD = """
import json, resource, sys, time
from gbpipe.measured import read
spec = json.loads(sys.argv[1])
t = time.perf_counter()
if spec:
    ds = read(spec, sys.argv[2])
    n = ds.sizes["time"]
else:
    n = 0
print(json.dumps({"seconds": time.perf_counter() - t, "samples": n,
                  "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def _signals(start: int, n: int, fs: float) -> dict[str, np.ndarray]:
    t = (start + np.arange(n)) / fs
    rng = np.random.default_rng(start)
    return {c: 1000.0 * (k + 1) + np.sin(2 * np.pi * (17 + 5 * k) * t)
            + 0.01 * rng.standard_normal(n) for k, c in enumerate(CHANNELS)}


def write_tdms(path: Path, n: int, fs: float) -> None:
    with TdmsWriter(path) as w:
        for s in range(0, n, BLOCK):
            sig = _signals(s, min(BLOCK, n - s), fs)
            w.write_segment([ChannelObject("bench", c, v, properties={
                "wf_increment": 1.0 / fs, "unit_string": "N*m"}) for c, v in sig.items()])


def write_csv(path: Path, n: int, fs: float) -> None:
    with open(path, "w") as fh:
        fh.write("time," + ",".join(CHANNELS) + "\n")
        for s in range(0, n, BLOCK):
            m = min(BLOCK, n - s)
            sig = _signals(s, m, fs)
            block = np.column_stack([(s + np.arange(m)) / fs, *sig.values()])
            np.savetxt(fh, block, delimiter=",", fmt="%.10g")


def spec_for(fmt: str, path: Path, fs: float) -> dict:
    f = {"path": path.name} if fmt == "tdms" else {"path": path.name, "time": "time"}
    ch = (lambda c: f"bench/{c}") if fmt == "tdms" else (lambda c: c)
    return {"files": {"f": f}, "sample_rate": fs,
            "signals": {c: {"file": "f", "channel": ch(c), "unit": "N*m"} for c in CHANNELS}}


def run_child(spec: dict, base: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", _CHILD, json.dumps(spec), str(base)],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=250_000, help="1x length per channel")
    ap.add_argument("--fs", type=float, default=10_000.0)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        idle = run_child({}, base)
        print(f"imports only: peak RSS {idle['rss_mb']:.0f} MB")
        print(f"{'format':6} {'x':>2} {'samples':>9} {'file MB':>8} {'s':>6} {'MB/s':>7} "
              f"{'Msamp/s':>8} {'RSS MB':>7} {'RSS-imp':>7}")
        for fmt, writer in (("tdms", write_tdms), ("csv", write_csv)):
            for mult in (1, 2, 4):
                n = mult * args.samples
                path = base / f"r{mult}.{fmt}"
                t = time.perf_counter()
                writer(path, n, args.fs)
                t_write = time.perf_counter() - t
                r = run_child(spec_for(fmt, path, args.fs), base)
                mb = path.stat().st_size / 1e6
                print(f"{fmt:6} {mult:>2} {n:>9} {mb:>8.1f} {r['seconds']:>6.2f} "
                      f"{mb / r['seconds']:>7.1f} {n * len(CHANNELS) / r['seconds'] / 1e6:>8.2f} "
                      f"{r['rss_mb']:>7.0f} {r['rss_mb'] - idle['rss_mb']:>7.0f}"
                      f"   (written in {t_write:.1f} s)")
                path.unlink()


if __name__ == "__main__":
    main()
