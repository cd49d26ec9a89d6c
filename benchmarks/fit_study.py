"""Study: the fit stage on simulated records of a perturbed bench, over many seeds.

Each seed is one run of the workflow (``snakemake --configfile
config/examples/fit_perturbed.yaml``, the noise seed changed) in a scratch copy of this
repository, up to ``results/fit/ms_torque_square.nc``: the bench with six parameters at
±30 % is simulated, identified (PBSID) and fitted from the nominal bench. Printed per
seed: the error of each identified parameter [%], whether its 95 % interval covers the
truth, the fitted delay and the fit job's time; then the largest error, the coverage
over all seeds and the job times.

Usage: ``python benchmarks/fit_study.py [--seeds 20] [--version regression|clean]
[--workdir DIR]`` (about 1 min per seed on 2 cores).
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

from gbpipe import io
from gbpipe.config import load
from gbpipe.fit.keypath import get_value

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "config" / "examples" / "fit_perturbed.yaml"
RECORD = "ms_torque_square"


def _copy(dest: Path) -> None:
    files = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=ROOT,
                           check=True, capture_output=True, text=True).stdout.split()
    for f in files:
        if not (ROOT / f).is_file():     # a submodule or link to a folder: not needed
            continue
        target = dest / f
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes((ROOT / f).read_bytes())


def run_workflow(work: Path, configfiles: list[str], overlay: dict, target: str) -> Path:
    """One workflow run in a scratch copy ``work`` of this repository up to ``target``.

    ``configfiles`` (repository paths) are given to snakemake, then ``overlay`` (written
    as ``overlay.yaml``); 2 cores, one thread each. Returns the target's path.
    """
    _copy(work)
    (work / "overlay.yaml").write_text(yaml.safe_dump(overlay))
    env = dict(os.environ, OMP_NUM_THREADS="1",
               PYTHONPATH=os.pathsep.join(filter(None, [str(work / "src"),
                                                        os.environ.get("PYTHONPATH")])))
    proc = subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", "--configfile",
                           *configfiles, "overlay.yaml", "--", target],
                          cwd=work, env=env, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"{work}: snakemake failed\n{proc.stderr[-3000:]}")
    return work / target


def run_seed(work: Path, seed: int, version: str) -> Path:
    """One workflow run of the study with noise seed ``seed``; the fit file's path."""
    return run_workflow(work, [str(STUDY)], {"seed": seed, "fit": {"version": version}},
                        f"results/fit/{RECORD}.nc")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--version", default="regression")
    ap.add_argument("--workdir", type=Path, default=None)
    args = ap.parse_args()
    base = load(ROOT / "config" / "config.yaml", STUDY)
    root = args.workdir or Path(tempfile.mkdtemp(prefix="gbpipe_fit_study_"))
    errors, covered, seconds = [], [], []
    for k in range(1, args.seeds + 1):
        seed = int(base["seed"]) + k
        path = run_seed(root / f"seed{k}", seed, args.version)
        ds = io.read(path)
        truth = np.array([get_value(base, str(p)) for p in ds.parameter.values])
        # determined by the data; "poor" when the fit failed its chi-square test
        ident = np.isin(ds.status.values, ["identified", "poor"])
        err = ds.estimate.values / truth - 1
        cov = (ds.interval_lower.values <= truth) & (truth <= ds.interval_upper.values)
        with open(path.parents[1] / "benchmarks" / "fit" / f"{RECORD}.tsv") as fh:
            job_s = float(next(csv.DictReader(fh, delimiter="\t"))["s"])
        errors.append(err[ident])
        covered.append(cov[ident])
        seconds.append(job_s)
        print(f"seed {seed}: errors [%] "
              + " ".join(f"{p}={e * 100:+.2f}{'' if c else '(not covered)'}" for p, e, c in
                         zip(ds.parameter.values[ident], err[ident], cov[ident], strict=True))
              + f"; unidentifiable: {[str(p) for p in ds.parameter.values[~ident]]}; fit "
              f"{ds.attrs['fit_status']} ({ds.attrs['fit_reason']}); delay "
              f"{float(ds.delay) * 1e3:.4f} ms; fit job {job_s:.1f} s", flush=True)
    e, c = np.concatenate(errors), np.concatenate(covered)
    print(f"\n{args.seeds} seeds, version {args.version}: largest error "
          f"{np.max(np.abs(e)) * 100:.2f} %; 95 % intervals cover the truth for "
          f"{c.mean() * 100:.1f} % of {c.size} estimates; fit job {min(seconds):.1f}-"
          f"{max(seconds):.1f} s (work in {root})")


if __name__ == "__main__":
    main()
