"""Steady state and statics of the simulated campaign over drivetrains nobody tuned it on.

For each seed, the shaft line of config/examples/shaftline_campaign.yaml gets every disk
inertia and shaft/mount stiffness scaled by a random factor 0.7–1.4 (log-uniform), a
nominal speed of 300–3000 rpm and torque of 50–600 N·m at the output, and each of the
four ramp tests is simulated without ripple and sensor noise
(:func:`gbpipe.simulate.test`). Printed per seed: the largest relative error, over the
settle window, of the drive speed against ``speed_ref``, of the load speed against the
gear ratio from the teeth, of the output torque and load motor torque against
``torque_ref``, and of the input torque against ``torque_ref`` times the ratio (statics
of a gearbox whose housing carries the difference); and, after the hold, the relative
error of the stepped set-point's mean over the last second (the loops' integral action).

Usage: ``OMP_NUM_THREADS=1 python benchmarks/chain_campaign.py [--seeds 10]``.
"""

from __future__ import annotations

import argparse
import copy
import resource
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from gbpipe import simulate  # noqa: E402
from gbpipe.config import load  # noqa: E402

TESTS = ("speed_up", "speed_down", "torque_up", "torque_down")


def _case(base, rng):
    dt = copy.deepcopy(base["drivetrain"])
    for disk in dt["disks"].values():
        disk["inertia"] *= float(np.exp(rng.uniform(np.log(0.7), np.log(1.4))))
    for el in (*dt["shafts"], *dt["mounts"]):
        el["stiffness"] *= float(np.exp(rng.uniform(np.log(0.7), np.log(1.4))))
    for m in dt["motors"]:
        m["ripple"] = 0.0
    rpm, torque = float(rng.uniform(300, 3000)), float(rng.uniform(50, 600))
    noise = {"sensor": {"speed": 0.0, "torque": 0.0}}
    camp = {"nominal": {"speed_rpm": rpm, "torque": torque},
            "full_range": {"speed_rpm": 4000.0, "torque": 1500.0, "ramp_time": 30.0}}
    # the loops' gains stay the example's: a case whose loops go unstable is refused
    return ({"drivetrain": dt, "noise": noise, "campaign": camp, "fit": {"records": []}},
            rpm, torque)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=10)
    args = ap.parse_args()
    files = (ROOT / "config/config.yaml", ROOT / "config/examples/shaftline_campaign.yaml")
    base = load(*files)
    ratio = np.prod([a / b for a, b in (g["teeth"] for g in base["drivetrain"]["gears"])])
    cpu0 = resource.getrusage(resource.RUSAGE_SELF).ru_utime
    print("seed   rpm  torque  steady_max_rel  step_end_max_rel  refused")
    worst = [0.0, 0.0]
    for seed in range(args.seeds):
        over, rpm, torque = _case(base, np.random.default_rng(seed))
        try:
            cfg = load(*files, over)
        except Exception as exc:  # an unstable loop of a far-off chain: say so, go on
            print(f"{seed:4d} {rpm:5.0f} {torque:7.1f}  -  -  {type(exc).__name__}: {exc}")
            continue
        camp = cfg["campaign"]
        fs, settle, hold = camp["sample_rate"], camp["settle"], camp["hold"]
        n0 = int(settle * fs) - 2
        steady, step_end = 0.0, 0.0
        for test in TESTS:
            ds = simulate.test(cfg, test, "square")
            w, tq = ds.speed_ref.values[0], ds.torque_ref.values[0]
            pairs = (("speed_motor", w), ("speed_load", w * ratio), ("torque_output", tq),
                     ("motor_torque_load", tq), ("torque_input", tq * ratio))
            for name, expect in pairs:
                steady = max(steady, np.abs(ds[name].values[:n0] / expect - 1).max())
            t = ds.time.values
            end = (t > settle + hold - 1.0) & (t < settle + hold - 0.01)
            name = "speed_motor" if test.startswith("speed") else "torque_output"
            ref = ds["speed_ref" if test.startswith("speed") else "torque_ref"].values[end]
            step_end = max(step_end, abs(ds[name].values[end].mean() / ref.mean() - 1))
        worst = [max(worst[0], steady), max(worst[1], step_end)]
        print(f"{seed:4d} {rpm:5.0f} {torque:7.1f}  {steady:14.2e}  {step_end:16.2e}  -")
    cpu = resource.getrusage(resource.RUSAGE_SELF).ru_utime - cpu0
    print(f"worst: steady {worst[0]:.2e}, step end {worst[1]:.2e}; CPU {cpu:.1f} s")


if __name__ == "__main__":
    main()
