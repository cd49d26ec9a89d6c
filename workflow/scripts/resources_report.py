"""Resources each rule declares against what its jobs used (their logs and benchmark logs).

    python workflow/scripts/resources_report.py [RESULTS ...] [--csv FILE] [--propose]

RESULTS are results folders (default ``results``; a study's ``results/<name>`` folders may
be given together: each rule's largest use over all of them counts). The table compares
each rule's declaration in ``workflow/resources.yaml`` (the script's memory share, without
the Snakemake overhead) with the largest peak memory of its jobs (each job logs its own
at its exit; a job whose log lacks it, e.g. a killed one, is counted in
``unmeasured_jobs``, not as using 0 MB) and their longest wall time (Snakemake's
benchmark logs). The exit status is 1 when a rule's measured
peak memory or wall time exceeds its declaration, or a rule that ran is not declared.

``--propose`` prints, instead, a ``rules:`` section derived from the measurement with the
headroom of ``workflow/resources.yaml``; paste it there after a full default run.

Not a Snakemake job: it reads what finished jobs wrote (docs/cluster.md).
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lib"))
import jobresources  # noqa: E402  (the workflow's own helpers, beside this folder)

COLUMNS = ("rule", "jobs", "threads", "declared_mem_mb", "measured_rss_mb",
           "unmeasured_jobs", "declared_runtime_min", "measured_wall_s", "measured_cpu_s",
           "status")


def _measured(folders: list[Path]) -> dict[str, jobresources.Measured]:
    """Each rule's largest use over several results folders."""
    for folder in folders:
        if not (folder / "benchmarks").is_dir():
            raise SystemExit(f"{folder}/benchmarks does not exist: run the workflow first "
                             "(every rule writes a benchmark log there)")
    return jobresources.measured_in(*folders)


def _markdown(rows: list[dict]) -> str:
    def cell(v):
        return "" if v is None else str(v)
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    lines += ["| " + " | ".join(cell(r[c]) for c in COLUMNS) + " |" for r in rows]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("results", nargs="*", type=Path, default=[Path("results")])
    parser.add_argument("--declared", type=Path, default=jobresources.DECLARATIONS,
                        help="declarations file (default: workflow/resources.yaml)")
    parser.add_argument("--csv", type=Path, help="also write the table as CSV")
    parser.add_argument("--propose", action="store_true",
                        help="print declarations derived from the measurement")
    args = parser.parse_args(argv)

    declared = jobresources.Declared(args.declared)
    use = _measured(args.results)
    if args.propose:
        print(f"rules:  # from {', '.join(map(str, args.results))}; headroom "
              f"{declared.headroom}")
        for rule, m in use.items():
            try:
                p = jobresources.propose(m, declared.headroom)
            except ValueError as exc:   # no job logged its peak memory
                print(f"  # {exc}")
                continue
            print(f"  {rule}: {{threads: {p['threads']}, mem_mb: {p['mem_mb']}, "
                  f"runtime: {p['runtime']}}}  # {m.jobs} jobs, peak {m.max_rss_mb:.0f} MB, "
                  f"longest {m.max_wall_s:.1f} s")
        return 0

    rows = jobresources.compare(declared, use)
    print(f"Declared (workflow/resources.yaml; memory: the script's share, a job asks for "
          f"{declared.overhead_mb} MB more) against measured (job logs and benchmark logs of "
          f"{', '.join(map(str, args.results))}):\n")
    print(_markdown(rows))
    if args.csv:
        with open(args.csv, "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=COLUMNS)
            writer.writeheader()
            writer.writerows(rows)
    bad = [r["rule"] for r in rows if r["status"] not in ("ok", "not run")]
    if bad:
        print(f"\nexceeded or undeclared: {', '.join(bad)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
