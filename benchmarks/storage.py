"""Size and CPU of the NetCDF writes (gbpipe.io.write) against uncompressed float64.

For each sensor-noise scale (the config's ``noise.sensor`` levels times 0.1, 1 and 10), one
closed-loop record (``speed_up``, square profile) is simulated and written three ways, in
alternation so that the machine's drift falls on each alike:

* ``raw``: every variable as the simulation made it (float64), uncompressed (xarray's
  ``to_netcdf`` of the CF-encoded dataset): the results' first form, 1.1 GB for the run;
* ``gbpipe``: :func:`gbpipe.io.write` as rule ``campaign`` calls it (the measured-like
  series named noisy): float32 on the step each series' noise leaves room for, zlib
  level 1 after the byte shuffle;
* ``gbpipe float64``: :func:`gbpipe.io.write` without naming any series noisy (every
  series float64, compressed): what the clean series cost.

Printed per case and way: file size [MB], CPU time of the write and of
:func:`gbpipe.io.read` [ms] (``time.process_time``, best of 3), and for ``gbpipe`` the
mantissa bits each measured-like series uses at most (its values are multiples of a
power-of-two step, :func:`gbpipe.io.storage.quantum`) with its stored rounding error's
margin under the series' spectrum (Welch, computed here from the stored values).

Usage: ``OMP_NUM_THREADS=1 python benchmarks/storage.py [--scales 0.1 1 10]``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import timeit
from pathlib import Path

import numpy as np
import xarray as xr
from scipy import signal

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from gbpipe import io, simulate  # noqa: E402
from gbpipe.config import load  # noqa: E402
from gbpipe.io.cf import encode  # noqa: E402


def _cpu(fn, repeats: int = 3) -> float:
    return min(timeit.repeat(fn, timer=time.process_time, number=1, repeat=repeats))


def _raw(ds: xr.Dataset, path: Path) -> None:
    encode(ds).to_netcdf(path, engine="netcdf4", format="NETCDF4")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scales", type=float, nargs="+", default=[0.1, 1.0, 10.0])
    args = ap.parse_args()
    base = load(ROOT / "config/config.yaml")
    tmp = Path(tempfile.mkdtemp())
    print("scale  way             MB   write_ms  read_ms")
    for scale in args.scales:
        sensor = {k: v * scale for k, v in base["noise"]["sensor"].items()}
        cfg = load(ROOT / "config/config.yaml", {"noise": {"sensor": sensor}})
        ds = simulate.test(cfg, "speed_up", "square")
        noisy = [v for v in ds.data_vars if str(v).endswith("_measured")]
        ways = {
            "raw": lambda p, ds=ds: _raw(ds, p),
            "gbpipe": lambda p, ds=ds, noisy=noisy: io.write(ds, p, stage="bench",
                                                             noisy=noisy),
            "gbpipe float64": lambda p, ds=ds: io.write(ds, p, stage="bench"),
        }
        for way, fn in ways.items():
            path = tmp / f"{way.replace(' ', '_')}.nc"
            write = _cpu(lambda fn=fn, path=path: fn(path))
            read = _cpu(lambda path=path: io.read(path))
            print(f"{scale:5.1f}  {way:15s} {path.stat().st_size / 1e6:6.2f} {write * 1e3:9.0f}"
                  f" {read * 1e3:8.0f}")
        back = io.read(tmp / "gbpipe.nc")
        fs = float(cfg["campaign"]["sample_rate"])
        for name in noisy:
            x = ds[name].values
            stored = back[name].values
            words = stored.view(np.uint32) if stored.dtype == np.float32 else None
            if words is None:
                print(f"        {name:32s} float64 (no room)")
                continue
            mant = words[words & 0x7FFFFF != 0]
            bits = 23 - int(np.log2(mant & (~mant + np.uint32(1))).min())
            _, pxx = signal.welch(x, fs, nperseg=1024)
            _, pee = signal.welch(stored.astype(np.float64) - x, fs, nperseg=1024)
            print(f"        {name:32s} {bits:2d} bits, margin "
                  f"{10 * np.log10(np.min(pxx[1:] / pee[1:])):5.1f} dB")


if __name__ == "__main__":
    main()
