"""Fit evidence on a shaft line nobody modelled: config/examples/shaftline.yaml.

For each seed, three parameters of the chain (the flywheel's inertia, the coupling
before the gearbox, the gear housing's torque arm: the example's ``fit.free``) are
perturbed by a random sign and size 15–40 %, a measured-like record is simulated from
the perturbed chain (tests/measured/shaftline_bench.py: the project's closed loop,
exact ZOH at 16× the record's rate behind an anti-alias filter, the drive motor excited
by a band-limited random torque, 2 % sensor noise), and the nonparametric FRF of the
record (:func:`gbpipe.identify.nonparametric_reference`: the closed-loop estimate through
the excitation, which the record carries as its reference, with its 95 % magnitude
bounds, kept where coherent, as the identify stage computes it for a bench record) of
the example's pairings is fitted from the nominal chain
(:func:`gbpipe.fit.estimate.fit_parameters`, sigma from the bounds, the model seen through
the estimate's Hann window, ``FrfData.segment``, as a ratio of smoothed spectra whose
input spectrum the drive motor's loop shapes, ``FrfData.excitation``; no delay: the
record's zero-order hold is removed from the data as its known response, a half-sample
lag and a sinc droop).
Printed per seed: errors, whether each 95 % interval covers the truth (a parameter
without an interval does not), the chi-square verdict, the cost ratio to the truth's.

Then the same from a modal table alone: the open-loop modes of the perturbed chain below
``--f-modes`` Hz, drawn with 0.5 % frequency and 10 % damping spread around the truth
(:func:`gbpipe.fit.modes.modal_data_of`, a synthetic table, not the stabilization
diagram's): errors of the identified parameters and the combinations named.

Each cause of yesterday's misses can be put back: ``--h1`` (H1 instead of the
reference-based estimate: the noise of the measured motor torque biases it),
``--no-window`` (the model compared with the Welch estimate as if it were the FRF itself:
resolution bias at the modes), ``--flat-input`` (the window kept, the input's spectrum
taken as flat over it: ``K⊛G`` instead of ``K⊛(G·P)/K⊛P``), ``--oversample 1`` (the
record sampled straight from the held-excitation simulation: the excitation's images in
the motor torque bias every output/torque ratio near a mode, up to 7 %).

``--overlay benchmarks/chains/shaftline_long.yaml`` runs the same on the shaft line drawn
as 22 disks with three gear stages (its shafts in segments, a third stage).

Usage: ``OMP_NUM_THREADS=1 python benchmarks/fit_chain.py [--seeds 20] [--duration 30]
[--h1] [--no-window] [--flat-input] [--oversample 16] [--overlay FILE ...]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from gbpipe.config import load
from gbpipe.fit.estimate import fit_parameters
from gbpipe.fit.keypath import get_value
from gbpipe.fit.modes import ModalResiduals, modal_data_of
from gbpipe.fit.parameters import FreeParameters
from gbpipe.fit.residuals import FrfResiduals

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from tests.measured.shaftline_bench import OVERSAMPLE, perturbed, record_data  # noqa: E402

FS = 2000.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--duration", type=float, default=30.0, help="record length [s]")
    ap.add_argument("--h1", action="store_true",
                    help="H1 FRFs instead of the estimate through the excitation (S_yr/S_ur)")
    ap.add_argument("--no-window", action="store_true",
                    help="compare the Welch estimate with the model itself, not with the "
                         "model seen through the window")
    ap.add_argument("--flat-input", action="store_true",
                    help="the window kept, the excitation not named: the input's spectrum "
                         "taken as flat over the kernel")
    ap.add_argument("--oversample", type=int, default=OVERSAMPLE,
                    help="simulation rate over the record's (1: no anti-alias filter)")
    ap.add_argument("--f-modes", type=float, default=350.0,
                    help="modal table up to [Hz] (default: the identification band's top)")
    ap.add_argument("--overlay", type=Path, nargs="*", default=[],
                    help="config overlays on top of shaftline.yaml, e.g. "
                         "benchmarks/chains/shaftline_long.yaml (22 disks, 3 gears)")
    args = ap.parse_args()
    cfg = load(ROOT / "config" / "config.yaml", ROOT / "config" / "examples" / "shaftline.yaml",
               *args.overlay)
    print(f"chain {cfg['drivetrain']['name']!r}: {len(cfg['drivetrain']['disks'])} disks, "
          f"{len(cfg['drivetrain']['shafts'])} shafts, {len(cfg['drivetrain']['gears'])} "
          f"gears; free {cfg['fit']['free']}", flush=True)
    free = list(cfg["fit"]["free"])
    fp = FreeParameters.from_config(cfg, free)
    fc = cfg["fit"]   # the workflow's search settings (workflow/scripts/fit.py)
    common = {"bounds": fc["bounds"], "factor": fc["factor"], "n_starts": fc["starts"],
              "search": fc["search"], "alpha": fc["alpha"], "accuracy": fc["accuracy"]}
    rows, rows_m, cpus = [], [], []
    for seed in range(args.seeds):
        rng = np.random.default_rng(seed)
        truth, factors = perturbed(cfg, free, rng)
        true = np.array([get_value(truth, p) for p in free])
        data = record_data(cfg, truth, seed, args.duration, FS, not args.h1, args.oversample)
        if args.no_window:
            data = [replace(d, segment=None, excitation=None) for d in data]
        elif args.flat_input:
            data = [replace(d, excitation=None) for d in data]
        r = FrfResiduals(fp, data, False).residual(np.log(factors))
        t = time.process_time()
        res = fit_parameters(cfg, data, free, seed=seed, **common)
        cpus.append(time.process_time() - t)
        err = 100 * (res.value / true - 1)
        cover = (res.interval[:, 0] <= true) & (true <= res.interval[:, 1])
        ratio = res.cost / (0.5 * float(r @ r))
        rows.append((err, cover, res.goodness.status, res.status))
        print(f"seed {seed}: factors {np.round(factors, 3)}, errors "
              f"{np.array2string(err, precision=2)} %, covered {cover.astype(int)}, "
              f"cost/truth {ratio:.3f}, goodness {res.goodness.status} "
              f"({res.goodness.reason}), CPU {cpus[-1]:.1f} s", flush=True)
        modal = modal_data_of(truth, None, args.f_modes, 0.005, 0.1, rng)
        rm = ModalResiduals(fp, modal).residual(np.log(factors))
        res_m = fit_parameters(cfg, modal, free, seed=seed, **common)
        err_m = 100 * (res_m.value / true - 1)
        cover_m = (res_m.interval[:, 0] <= true) & (true <= res_m.interval[:, 1])
        rows_m.append((err_m, res_m.identified, res_m.combinations, cover_m))
        print(f"    modes ({modal.frequency_hz.size} below {args.f_modes:g} Hz): errors "
              f"{np.array2string(err_m, precision=2)} %, covered {cover_m.astype(int)}, "
              f"status {res_m.status}, cost/truth "
              f"{res_m.cost / (0.5 * float(rm @ rm)):.3f}, cannot separate: "
              f"{res_m.combinations or 'none'}", flush=True)
    err = np.array([r[0] for r in rows])
    cover = np.array([r[1] for r in rows])
    n = len(rows)
    has = np.array([[s in ("identified", "poor") for s in r[3]] for r in rows])
    with_interval = dict(zip(free, has.sum(axis=0).tolist(), strict=True))
    print(f"\nFRF fit, {n} seeds: largest |error| per parameter "
          f"{dict(zip(free, np.round(np.abs(err).max(axis=0), 2), strict=True))} %; "
          f"seeds with every parameter within 3 %: {int(np.sum(np.all(np.abs(err) <= 3, 1)))} "
          f"of {n}; 95 % interval coverage per parameter "
          f"{dict(zip(free, np.round(100 * cover.mean(axis=0), 1), strict=True))} %; "
          f"with an interval (identified or poor) per parameter {with_interval}; "
          f"goodness passed in {sum(r[2] == 'passed' for r in rows)} of {n}; CPU per fit median "
          f"{np.median(cpus):.1f} s")
    err_m = np.array([r[0] for r in rows_m])
    ident = np.array([r[1] for r in rows_m])
    worst = [float(np.max(np.abs(err_m[ident[:, j], j]))) if ident[:, j].any() else np.nan
             for j in range(len(free))]
    combos = sorted({c for r in rows_m for c in r[2]})
    print(f"modal-table fit, {n} seeds: identified per parameter "
          f"{dict(zip(free, ident.sum(axis=0).tolist(), strict=True))} of {n}; largest "
          f"|error| of identified ones {dict(zip(free, np.round(worst, 2), strict=True))} %; "
          f"within 5 %: {int(np.sum(np.abs(err_m[ident]) <= 5))} of {int(ident.sum())}; "
          f"95 % interval coverage {100 * np.mean([r[3] for r in rows_m]):.1f} %; "
          f"combinations named: {combos or 'none'}")


if __name__ == "__main__":
    main()
