"""Run ``snakemake -n`` on many configurations, two at a time, paying its start-up once.

Usage: ``python snakemake_batch.py CASES.json RESULTS.json``. CASES.json lists
``{"dir": ..., "argv": [...]}``; each case runs Snakemake's own command-line entry point
(``snakemake.cli.main``, what the ``snakemake`` command calls) in a forked child whose
working directory is ``dir`` and whose stdout/stderr go to ``dir/stdout``/``dir/stderr``.
Snakemake and gbpipe are imported once, before forking, which saves ~3 s per case; so
are what every case would build again before its config is refused: Snakemake's plugin
registries (built with its argument parser), gbpipe's parsed config schema, and the URI
parser Snakemake imports when it opens the Snakefile (smart_open and requests, 0.34 s of
a case's 0.63 s; the children inherit all three, filled, from the parent).
RESULTS.json gets the exit status of each case, in order.
"""

from __future__ import annotations

import json
import os
import sys

import snakemake.cli
from snakemake.common import parse_uri

from gbpipe.config import schema  # gbpipe.config imported once here: the Snakefile does


def _child(case: dict) -> None:
    os.chdir(case["dir"])
    for fd, name in ((1, "stdout"), (2, "stderr")):
        out = os.open(os.path.join(case["dir"], name), os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
        os.dup2(out, fd)
    try:
        snakemake.cli.main(case["argv"])
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    except BaseException:
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def main(cases_path: str, results_path: str, jobs: int = 2) -> None:
    with open(cases_path) as fh:
        cases = json.load(fh)
    # singletons and caches that every child would fill again: filled once, here
    snakemake.cli.get_argument_parser()
    schema()
    parse_uri("Snakefile")   # its first call imports smart_open (and requests)
    codes: dict[int, int] = {}
    running: dict[int, int] = {}
    for i, case in enumerate(cases):
        while len(running) >= jobs:
            pid, status = os.wait()
            codes[running.pop(pid)] = os.waitstatus_to_exitcode(status)
        pid = os.fork()
        if pid == 0:
            _child(case)
        running[pid] = i
    while running:
        pid, status = os.wait()
        codes[running.pop(pid)] = os.waitstatus_to_exitcode(status)
    with open(results_path, "w") as fh:
        json.dump([codes[i] for i in range(len(cases))], fh)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
