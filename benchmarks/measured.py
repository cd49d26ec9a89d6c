"""Streaming benchmark of :func:`gbpipe.measured.read` with ``out=``: MB/s and peak RSS
for 1x, 2x and 4x a record length, for TDMS and CSV (4 channels at 10 kHz, CSV with a
time column), and with ``--full`` the 2-hour record (72 M samples x 4 channels, 2.3 GB
of float64).

Each read runs in a fresh interpreter so its peak RSS (``ru_maxrss``) is its own; the
"imports" row is the same interpreter importing gbpipe.measured and reading nothing.
The read writes the record block by block into a NetCDF file and opens it lazily,
without xarray's ``time`` index (``--index``: with it, as ``read`` does for records up to
2**23 samples; building it costs about 24 bytes per sample at the peak). Time should grow
linearly with the length, the RSS not at all.

Usage: ``OMP_NUM_THREADS=1 python benchmarks/measured.py [--samples 2000000] [--fs 10000]
[--full] [--index] [--formats tdms csv]``
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
from pathlib import Path
from gbpipe.measured import read, writer
spec = json.loads(sys.argv[1])
if sys.argv[3] == "no-index":
    writer.INDEX_LIMIT = 0  # the RSS of the streaming alone, not of xarray's time index
t = time.perf_counter()
if spec:
    out = Path(sys.argv[2]) / "record.nc"
    ds = read(spec, sys.argv[2], out=out)
    n = ds.sizes["time"]
    ds.close()
    out_mb = out.stat().st_size / 1e6
    out.unlink()
else:
    n, out_mb = 0, 0.0
print(json.dumps({"seconds": time.perf_counter() - t, "samples": n, "out_mb": out_mb,
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


def run_child(spec: dict, base: Path, index: bool = False) -> dict:
    out = subprocess.run([sys.executable, "-c", _CHILD, json.dumps(spec), str(base),
                          "index" if index else "no-index"],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _row(fmt: str, label: str, n: int, base: Path, fs: float, writer, idle: dict,
         index: bool) -> None:
    path = base / f"r{label}.{fmt}"
    t = time.perf_counter()
    writer(path, n, fs)
    t_write = time.perf_counter() - t
    r = run_child(spec_for(fmt, path, fs), base, index)
    mb = path.stat().st_size / 1e6
    print(f"{fmt:6} {label:>4} {r['samples']:>9} {mb:>8.1f} {r['seconds']:>7.2f} "
          f"{mb / r['seconds']:>7.1f} {n * len(CHANNELS) / r['seconds'] / 1e6:>8.2f} "
          f"{r['rss_mb']:>7.0f} {r['rss_mb'] - idle['rss_mb']:>7.0f} {r['out_mb']:>7.0f}"
          f"   (input written in {t_write:.1f} s)", flush=True)
    path.unlink()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=2_000_000, help="1x length per channel")
    ap.add_argument("--fs", type=float, default=10_000.0)
    ap.add_argument("--full", action="store_true",
                    help="also the 2-hour record at --fs, for each format (CSV: 4 GB of "
                         "text, written in about 4 min)")
    ap.add_argument("--index", action="store_true",
                    help="let read() build xarray's time index as it does by default for "
                         "records up to 2**23 samples (24 bytes per sample at the peak)")
    ap.add_argument("--formats", nargs="+", default=["tdms", "csv"])
    args = ap.parse_args()
    writers = {"tdms": write_tdms, "csv": write_csv}
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        idle = run_child({}, base)
        print(f"imports only: peak RSS {idle['rss_mb']:.0f} MB")
        print(f"{'format':6} {'x':>4} {'samples':>9} {'file MB':>8} {'s':>7} {'MB/s':>7} "
              f"{'Msamp/s':>8} {'RSS MB':>7} {'RSS-imp':>7} {'out MB':>7}", flush=True)
        for fmt in args.formats:
            for mult in (1, 2, 4):
                _row(fmt, str(mult), mult * args.samples, base, args.fs, writers[fmt], idle,
                     args.index)
        for fmt in args.formats if args.full else ():
            _row(fmt, "2h", int(round(7200 * args.fs)), base, args.fs, writers[fmt], idle,
                 args.index)


if __name__ == "__main__":
    main()
