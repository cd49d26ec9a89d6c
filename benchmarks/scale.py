"""Hour-long bench records through the measured workflow: wall, CPU and peak memory of
every stage at 6, 20 and 60 min (issue 47), and the growth exponent of each.

The records are the shaft line of ``config/examples/shaftline.yaml`` with one more speed
sensor (8 channels and a tacho, 5 kHz), simulated exactly in blocks of one minute
(:func:`gbpipe.lti.lsim` carrying the state; the excitation filter carries its own) and
written the way ``tests/measured/shaftline_bench.py`` writes them: the motor torques in a
CSV with a time column, the sensors, the excitation and the tacho in a TDMS file (one
segment per block). The workflow runs on them with the example's config and the fit, in
its own results folder; each job logs its own peak RSS and CPU time at exit
(``results/logs/``), Snakemake its wall (``results/benchmarks/``). With ``--removal`` the
removals the measured workflow does not run on this record are timed, each in a child
process on the record the workflow read, opened lazily as the stages open it (a signal is
read when it is removed; its own ``getrusage``; its log, with the progress and heartbeat
lines, in ``results/logs/removal_<method>.log``), ``--jobs`` of them at a time as
Snakemake would run them: the regression and the VKF by
:func:`gbpipe.harmonics.method_residuals` (the chain's own order families), and TSA by
:func:`gbpipe.harmonics.record_residuals`, the ``tsa_measured`` stage, with the cycles of
``tsa.tests`` on the paper's gearbox (the workflow runs TSA only on records of that
gearbox: on this chain its cycles are not the lines' ones, but its work is the same).

The example's config includes the ``virtual`` stage (since the merge of branch ``virt``):
its filter, smoother and output run in blocks, 1.6 GB at 60 min (docs/cluster.md, "The
virtual sensor"); ``--until virtual`` times it alone.

For each stage the exponent ``p`` of ``cost ~ minutes**p`` is the least-squares slope of
``log cost`` on ``log minutes`` over the record lengths given (a stage under 2 s of CPU at
the longest record is dominated by its imports and is marked ``floor``). The largest gap
between two lines of a job's log is its silence: a stage over 10 s must stay under 10 s.

Usage: ``PYTHONPATH=$PWD/src python benchmarks/scale.py [--minutes 6 20 60] [--fs 5000]
[--work /tmp/gbpipe_scale] [--jobs 2] [--removal [vkf tsa regression] [--removal-signals N]]
[--until RULE ..]
[--json FILE]``
"""

from __future__ import annotations

import argparse
import copy
import datetime as dt
import json
import re
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from nptdms import ChannelObject, TdmsWriter
from scipy import signal
from scipy.integrate import cumulative_trapezoid

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "workflow" / "lib"))
import jobresources  # noqa: E402  (the workflow's own helpers: rule of a log)

from gbpipe.io.runlog import job_resources  # noqa: E402
from gbpipe.lti import lsim  # noqa: E402
from gbpipe.model.assembly import bench_ss  # noqa: E402
from gbpipe.model.stability import check_stability  # noqa: E402
from tests.measured.bench_campaign import EPOCH, tacho_of_angle  # noqa: E402
from tests.measured.shaftline_bench import (  # noqa: E402  (the test bench's record)
    EXCITATION_BAND,
    EXCITATION_SHARE,
    LOAD_TORQUE,
    NOISE_SHARE,
    SPEED,
    example_drivetrain,
    speed_sensor,
    static_offset,
    static_speeds,
)

EXAMPLE = ROOT / "config" / "examples" / "shaftline.yaml"
BLOCK_S = 60.0          # s simulated and written at once
EXTRA_SENSOR = {"name": "speed_flywheel", "speed": "flywheel"}   # the 8th channel
REMOVALS = ("vkf", "tsa", "regression")   # --removal: timed after the workflow, longest first
LOG_TIME = re.compile(r"^(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d{3}) ")

_REMOVAL_CHILD = """
import json, resource, sys, time
import numpy as np
from gbpipe import io
from gbpipe.config import load
io.setup_log(sys.argv[3])  # progress and heartbeat lines: the longest silence
from gbpipe.harmonics import (method_params, method_residuals, record_residuals,
                               test_families)
from gbpipe.harmonics.stage import MODE_MIN_FREQUENCY
from gbpipe.model.assembly import bench_ss
cfg = load(*sys.argv[5:])
rec = io.read(sys.argv[1], lazy=True)  # a signal is read when removed, not all nine
names = [n for n in rec.data_vars if "time" in rec[n].dims and n != "tacho"]
names = names[:int(sys.argv[4])] if int(sys.argv[4]) else names
fam = test_families(cfg)
# the chain's closed-loop modes (the regression's modal envelope), as envelope_modes keeps
lam = np.linalg.eigvals(bench_ss(cfg).A)
f, z = np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam)
keep = (lam.imag > 0) & (f > MODE_MIN_FREQUENCY) & (f < cfg["spectra"]["mode_max_frequency"])
t = time.perf_counter()
if sys.argv[2] == "tsa":  # the tsa_measured stage (its config, as the rule builds it)
    record_residuals(rec, names, cfg["gearbox"]["stages"], cfg["tsa"],
                     cfg["identify"]["tsa_keep_below"])
else:
    params = method_params(cfg["removal"], sys.argv[2], fam,
                           np.column_stack([f[keep], z[keep]]))
    method_residuals(rec, names, sys.argv[2], params, fam, cfg["identify"]["tsa_keep_below"])
u = resource.getrusage(resource.RUSAGE_SELF)
hwm = next(float(x.split()[1]) / 1e3 for x in open("/proc/self/status")
           if x.startswith("VmHWM"))
print(json.dumps({"wall_s": time.perf_counter() - t, "cpu_s": u.ru_utime + u.ru_stime,
                  "rss_mb": hwm}))
"""


def drivetrain() -> dict:
    """The example's chain with :data:`EXTRA_SENSOR` (``{"drivetrain": ...}``)."""
    cfg = copy.deepcopy(example_drivetrain())
    cfg["drivetrain"]["sensors"].append(dict(EXTRA_SENSOR))
    return cfg


def write_record(folder: Path, minutes: float, fs: float, seed: int = 1,
                 name: str = "run1") -> dict:
    """Simulate the chain for ``minutes`` at ``fs`` [Hz] in blocks and write its bench
    files into ``folder``; return the ``measured:`` entry (absolute paths).

    The drive motor is excited by a band-limited random torque (its rms
    ``EXCITATION_SHARE * LOAD_TORQUE``, scaled on the first block), every signal gets
    white noise of ``NOISE_SHARE`` of its first block's dynamic rms, and the static
    operating point of ``shaftline_bench`` is added.
    """
    cfg = drivetrain()
    check_stability(cfg)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    ss = bench_ss(cfg)
    desc = cfg["drivetrain"]
    speeds = static_speeds(cfg, SPEED)
    motor = desc["motors"][0]["name"]
    tacho_out = ss.outputs.index(speed_sensor(desc, "load"))
    b, a = signal.butter(4, EXCITATION_BAND, fs=fs)
    zi = np.zeros(max(len(a), len(b)) - 1)
    x0 = theta0 = None
    gain = noise = None
    n_total = int(round(minutes * 60.0 * fs))
    n_block = int(round(BLOCK_S * fs))
    motors = [f"motor_torque_{m['name']}" for m in desc["motors"]]
    csv_path, tdms_path = folder / f"{name}_motors.csv", folder / f"{name}.tdms"
    props = {"wf_increment": 1.0 / fs, "wf_start_offset": 0.0, "wf_start_time": EPOCH}
    with open(csv_path, "w") as fh, TdmsWriter(tdms_path) as w:
        for start in range(0, n_total, n_block):
            n = min(n_block, n_total - start)
            t = (start + np.arange(n)) / fs
            exc, zi = signal.lfilter(b, a, rng.standard_normal(n), zi=zi)
            gain = EXCITATION_SHARE * LOAD_TORQUE / exc.std() if gain is None else gain
            u = np.zeros((n, len(ss.inputs)))
            u[:, ss.inputs.index(f"disturbance_{motor}")] = gain * exc
            y, x0 = lsim(ss, u, 1.0 / fs, x0=x0)
            noise = NOISE_SHARE * y.std(axis=0) if noise is None else noise
            sig = {o: y[:, j] + noise[j] * rng.standard_normal(n)
                   + static_offset(desc, o, speeds) for j, o in enumerate(ss.outputs)}
            rate = speeds["load"] + y[:, tacho_out]
            theta = cumulative_trapezoid(rate, t, initial=0.0) + (theta0 or 0.0)
            theta0 = theta[-1] + rate[-1] / fs  # the next block's first sample
            sig["tacho"] = tacho_of_angle(theta, 1)
            sig[f"excitation_{motor}"] = gain * exc
            pd.DataFrame({"time": t, **{m: sig[m] for m in motors}}).to_csv(
                fh, index=False, header=start == 0, float_format="%.12g")
            w.write_segment([ChannelObject("Sensors", s, v, properties={
                **props, "unit_string": "V" if s == "tacho" else
                "rad/s" if s.startswith("speed") else "N*m"})
                for s, v in sig.items() if s not in motors])
    sensors = [s for s in sig if s not in motors and s != "tacho"]
    return {"files": {"motors": {"path": str(csv_path), "time": "time"},
                      "daq": {"path": str(tdms_path)}},
            "sample_rate": fs,
            "signals": {**{m: {"file": "motors", "channel": m, "unit": "N*m"} for m in motors},
                        **{s: {"file": "daq", "channel": f"Sensors/{s}"} for s in sensors},
                        "tacho": {"file": "daq", "channel": "Sensors/tacho",
                                  "quantity": "tacho", "pulses_per_rev": 1}},
            "gaps": "refuse", "orders": []}


def overlay(spec: dict, results: Path) -> dict:
    """Config overlay of the example for one record: the record, the 8th channel in the
    chain, its own results folder."""
    return {"results": str(results), "drivetrain": drivetrain()["drivetrain"],
            "measured": {"run1": spec},
            # one line-carrying shaft angle (the tacho's): no second angle to regress on
            "removal": {"regression": {"second_angle": []}}}


def stage_costs(results: Path) -> dict[str, dict]:
    """Per rule: summed wall [s] (Snakemake's benchmark logs), summed CPU [s] and largest
    peak RSS [MB] (the jobs' own log line), and the longest silence of its logs [s]."""
    out: dict[str, dict] = {}

    def row(rule: str) -> dict:
        return out.setdefault(rule, {"jobs": 0, "wall_s": 0.0, "cpu_s": 0.0, "rss_mb": 0.0,
                                     "silence_s": 0.0})
    root = results / "benchmarks"
    for tsv in sorted(root.rglob("*.tsv")):
        r = row(jobresources.rule_of(tsv, root))
        r["jobs"] += 1
        r["wall_s"] += jobresources.read_benchmark(tsv)["s"]
    patterns = jobresources.log_patterns()
    for log in sorted((results / "logs").rglob("*.log")):
        rel = log.relative_to(results).as_posix()
        rule = next((k for k, v in patterns.items() if v.fullmatch(rel)), None)
        peak = job_resources(log)
        if rule is None or peak is None:
            continue
        r = row(rule)
        r["rss_mb"] = max(r["rss_mb"], peak[0])
        r["cpu_s"] += peak[1]
        r["silence_s"] = max(r["silence_s"], longest_silence(log))
    return out


def longest_silence(log: Path) -> float:
    """Longest gap between two time-stamped lines of a job log [s]; its first line is
    written at the job's start (:func:`gbpipe.io.setup_log`'s first record is logged after
    the imports), its last at its exit."""
    stamps = [dt.datetime.strptime(m.group(1), "%Y-%m-%d %H:%M:%S,%f").timestamp()
              for line in log.read_text(errors="replace").splitlines()
              if (m := LOG_TIME.match(line))]
    return float(np.max(np.diff(stamps))) if len(stamps) > 1 else 0.0


def run_removals(results: Path, cfg_file: Path, methods: list[str], jobs: int,
                 signals: int) -> Iterator[tuple[str, dict]]:
    """Time each removal method in a child process (:data:`_REMOVAL_CHILD`), ``jobs`` at a
    time; yield (method, its costs) as each ends. A child that fails stops the others."""
    logs = results / "logs"
    waiting, running = list(methods), {}
    try:
        while waiting or running:
            while waiting and len(running) < jobs:  # as Snakemake runs jobs: `jobs` at once
                method = waiting.pop(0)
                with (open(logs / f"removal_{method}.out", "w") as out,
                      open(logs / f"removal_{method}.stderr", "w") as err):
                    running[method] = subprocess.Popen(
                        [sys.executable, "-c", _REMOVAL_CHILD,
                         str(results / "measured" / "run1.nc"), method,
                         str(logs / f"removal_{method}.log"), str(signals),
                         str(ROOT / "config" / "config.yaml"), str(EXAMPLE), str(cfg_file)],
                        stdout=out, stderr=err)
            time.sleep(0.5)
            for method, child in list(running.items()):
                if child.poll() is None:
                    continue
                del running[method]
                lines = (logs / f"removal_{method}.out").read_text().strip().splitlines()
                if child.returncode or not lines:
                    raise RuntimeError(f"the {method} removal failed (exit {child.returncode}"
                                       f"): see {logs / f'removal_{method}.stderr'}")
                r = json.loads(lines[-1])
                yield method, {"jobs": 1, "wall_s": r["wall_s"], "cpu_s": r["cpu_s"],
                               "rss_mb": r["rss_mb"],
                               "silence_s": longest_silence(logs / f"removal_{method}.log")}
    finally:  # a failure (or an interrupt) leaves no child running
        for child in running.values():
            child.terminate()
            child.wait()


def run_workflow(work: Path, minutes: float, fs: float, jobs: int,
                 removal: list[str] | None = None, until: list[str] | None = None,
                 removal_signals: int = 0) -> dict:
    """Write one record (unless its folder holds it), run the workflow on it (every rule,
    or with ``until`` only those rules and what they need), return the stage costs;
    ``removal``: the removal methods timed after it, ``jobs`` at a time,
    ``removal_signals``: on that many signals (0: all)."""
    folder = work / f"{minutes:g}min"
    t = time.perf_counter()
    spec_file = folder / "bench" / "spec.json"
    if spec_file.exists():   # the same record again (deterministic: seed 1)
        spec = json.loads(spec_file.read_text())
    else:
        spec = write_record(folder / "bench", minutes, fs)
        spec_file.write_text(json.dumps(spec))
    print(f"{minutes:g} min: bench files written in {time.perf_counter() - t:.0f} s",
          flush=True)
    results = folder / "results"
    cfg_file = folder / "overlay.yaml"
    cfg_file.write_text(yaml.safe_dump(overlay(spec, results), sort_keys=False))
    t = time.perf_counter()
    with open(folder / "snakemake.log", "w") as log:
        targets = ["--until", *until] if until else ["all"]  # first: --configfile takes
        subprocess.run(["snakemake", "-j", str(jobs), *targets,  # every word after it
                        "--configfile", str(EXAMPLE), str(cfg_file)],
                       cwd=ROOT, check=True, stdout=log, stderr=subprocess.STDOUT)
    wall = time.perf_counter() - t
    costs = stage_costs(results)
    t = time.perf_counter()
    for method, r in run_removals(results, cfg_file, list(dict.fromkeys(removal or [])),
                                  max(1, jobs), removal_signals):
        costs[f"removal_{method}*"] = r
    removal_wall = time.perf_counter() - t if removal else 0.0
    return {"minutes": minutes, "workflow_wall_s": wall, "removal_wall_s": removal_wall,
            "stages": costs}


def exponents(rows: list[dict]) -> dict[str, dict]:
    """Least-squares slope of log cost on log minutes, per stage and cost."""
    minutes = np.log([r["minutes"] for r in rows])
    out = {}
    for stage in rows[-1]["stages"]:
        if not all(stage in r["stages"] for r in rows):
            continue
        out[stage] = {k: float(np.polyfit(minutes, np.log([max(r["stages"][stage][k], 1e-3)
                                                           for r in rows]), 1)[0])
                      for k in ("wall_s", "cpu_s", "rss_mb")}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, nargs="+", default=[6.0, 20.0, 60.0])
    ap.add_argument("--fs", type=float, default=5000.0)
    ap.add_argument("--work", type=Path, default=Path("/tmp/gbpipe_scale"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", type=Path, help="also write the measurements here")
    ap.add_argument("--removal", nargs="*", choices=REMOVALS, metavar="METHOD",
                    help="also time these removals of every signal (default: "
                         f"{' '.join(REMOVALS)}; not workflow stages of this record; VKF: "
                         "about 1.4 s of CPU per signal and minute of record: "
                         "docs/cluster.md)")
    ap.add_argument("--removal-signals", type=int, default=0, metavar="N",
                    help="time the removals on the first N signals only (0: all; the VKF "
                         "takes them one at a time, the same work each)")
    ap.add_argument("--until", nargs="+", metavar="RULE",
                    help="run only these rules and those they need (e.g. virtual)")
    args = ap.parse_args()
    rows = []
    for minutes in args.minutes:
        removal = None if args.removal is None else (args.removal or list(REMOVALS))
        rows.append(run_workflow(args.work, minutes, args.fs, args.jobs, removal,
                                 args.until, args.removal_signals))
        r = rows[-1]
        print(f"\n{minutes:g} min at {args.fs:g} Hz: workflow {r['workflow_wall_s']:.0f} s "
              f"wall, then the removals {r['removal_wall_s']:.0f} s wall ({args.jobs} at a "
              f"time): {r['workflow_wall_s'] + r['removal_wall_s']:.0f} s")
        print(f"{'stage':32} {'jobs':>4} {'wall s':>8} {'CPU s':>8} {'RSS MB':>8} "
              f"{'silence s':>9}")
        for stage, c in r["stages"].items():
            print(f"{stage:32} {c['jobs']:>4} {c['wall_s']:>8.1f} {c['cpu_s']:>8.1f} "
                  f"{c['rss_mb']:>8.0f} {c['silence_s']:>9.1f}", flush=True)
    if len(rows) > 1:
        print(f"\nexponents p of cost ~ minutes**p ({', '.join(f'{m:g}' for m in args.minutes)}"
              " min)")
        print(f"{'stage':32} {'wall':>6} {'CPU':>6} {'RSS':>6}")
        for stage, p in exponents(rows).items():
            floor = " floor" if rows[-1]["stages"][stage]["cpu_s"] < 2.0 else ""
            print(f"{stage:32} {p['wall_s']:>6.2f} {p['cpu_s']:>6.2f} {p['rss_mb']:>6.2f}"
                  f"{floor}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
