"""Identification through an order/mode crossing: a designed speed ramp through 1244 rpm
(the 3x HSS order crosses the 62 Hz bench mode), measured-like, identified by PBSID clean,
raw, after the regression's harmonic removal (modal envelope), and the record's
random-only twin raw (the same noise, no line: ``twin``), against the true modes.

The record, the removal and the identification: tests/harmonics/crossing_identification.py
(shared with tests/harmonics/test_crossing_identification.py). Printed per seed, pairing
and version: each true mode of the pairing between 50 and 75 Hz, the nearest identified
mode, and its frequency and damping errors against the targets 1 % and 10 %; CPU time
per seed (simulation, model, removal, identification) and the peak resident memory.
Then, per pairing and version over the seeds, for the mode of each pairing the test
checks (the lowest in the band): how many seeds meet both targets, and the mean and
standard deviation of the damping error. The removal's own error is the regression's
against the twin's: both hold the same noise, only the twin never had a line.

``--knot-spacing`` sets the regression's default knot spacing (the envelope's share of
the random response, docs/removal.md).

Run::

    OMP_NUM_THREADS=1 python benchmarks/removal_crossing_identify.py [--seeds 1 2]
        [--knot-spacing 4]
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

from gbpipe.config import load

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "harmonics"))
from crossing_identification import crossed_modes, crossing_cfg  # noqa: E402  (shared)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    ap.add_argument("--seeds", nargs="*", type=int, default=[1, 2])
    ap.add_argument("--knot-spacing", type=float, default=None,
                    help="removal.regression.knot_spacing.default [s] (the configured "
                         "value when not given; the motor family keeps its own)")
    args = ap.parse_args()
    cfg = load(args.config)
    if args.knot_spacing is not None:
        cfg["removal"]["regression"]["knot_spacing"]["default"] = args.knot_spacing
    first = defaultdict(list)   # (pairing, version) -> (frequency, damping) errors [-]
    for seed in args.seeds:
        cpu = time.process_time()
        rows, info = crossed_modes(crossing_cfg(
            cfg, seed, versions=("clean", "raw", "regression", "twin")))
        print(f"seed {seed}: {info['samples']} samples, GB1 HSS {info['rpm'][0]:.0f}-"
              f"{info['rpm'][1]:.0f} rpm (3x HSS at 62.2 Hz: 1244 rpm); CPU "
              f"{time.process_time() - cpu:.1f} s")
        for (pairing, version), modes in rows.items():
            for ft, zt, fi, zi, status in modes:
                ef, ez = (fi - ft) / ft, (zi - zt) / zt
                met = "met" if abs(ef) <= 0.01 and abs(ez) <= 0.1 else "NOT met"
                print(f"  {pairing:>14} {version:>10}: true {ft:6.2f} Hz, zeta {zt:.4f}; "
                      f"identified {fi:6.2f} Hz ({100 * ef:+6.2f} %), zeta {zi:.4f} "
                      f"({100 * ez:+6.1f} %): {met} (1 %, 10 %); status {status}")
            ft, zt, fi, zi, _ = modes[0]
            first[(pairing, version)].append(((fi - ft) / ft, (zi - zt) / zt))
    print(f"lowest mode in the band, over {len(args.seeds)} seeds: seeds meeting 1 % and "
          f"10 %; damping error mean and standard deviation")
    for (pairing, version), errs in first.items():
        ef, ez = np.array(errs).T
        met = int(np.sum((np.abs(ef) <= 0.01) & (np.abs(ez) <= 0.1)))
        print(f"  {pairing:>14} {version:>10}: {met} of {len(errs)} met; damping "
              f"{100 * np.nanmean(ez):+6.1f} % +- {100 * np.nanstd(ez):5.1f} %")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3
    print(f"peak resident memory {peak:.0f} MB")


if __name__ == "__main__":
    main()
