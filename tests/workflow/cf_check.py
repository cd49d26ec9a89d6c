"""CF-1.11 compliance findings of a NetCDF file, as the IOOS compliance checker reports them.

Reusable by any test (e.g. one over every file of a workflow run)::

    from tests.workflow.cf_check import cf_findings
    assert cf_findings(path) == []

`cf_findings_of_files` checks many files in worker processes (the checker's cost grows
with a file's variables, ~4 s of CPU for an identification file, and a workflow run has
dozens): the second core does half the files.

Every finding counts, whatever its priority: high ("errors"), medium ("warnings") and low
("info"), which the command line's default ``--criteria normal`` would hide. An exception
inside one of the checker's checks is a finding too: the checker then could not verify
that part of the file (it happens, e.g., on string-valued coordinate variables).
"""

from __future__ import annotations

import multiprocessing
import os
import warnings
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from functools import lru_cache

CHECKER = "cf:1.11"
_PRIORITY = {3: "high", 2: "medium", 1: "low"}


@lru_cache(maxsize=1)
def _suite():
    # Loading the checker plugins costs ~1 s: do it once per process.
    with warnings.catch_warnings():
        # the checker's own plugins (ioos_sos) warn of their deprecation on import
        warnings.simplefilter("ignore", DeprecationWarning)
        from compliance_checker.runner import CheckSuite

        suite = CheckSuite()
        suite.load_all_available_checkers()
    return suite


def _walk(result, section: str, out: list[str]) -> None:
    scored, possible = result.value if isinstance(result.value, tuple) else (
        int(bool(result.value)), 1)
    name = result.name if isinstance(result.name, str) else " ".join(map(str, result.name))
    if scored < possible:
        priority = _PRIORITY.get(result.weight, str(result.weight))
        msgs = [m for m in result.msgs if m] or [f"{scored}/{possible} points"]
        out.extend(f"[{priority}] {section or name}: {m}" for m in msgs)
    for child in result.children or ():
        _walk(child, section or name, out)


def cf_findings(path: str | os.PathLike) -> list[str]:
    """Every CF-1.11 finding of the compliance checker on one file.

    Parameters
    ----------
    path : path-like
        A NetCDF file.

    Returns
    -------
    list of str
        ``"[priority] section: message"`` per finding, and ``"[exception] check: error"``
        per check that raised; empty if the file is compliant.
    """
    suite = _suite()
    ds = suite.load_dataset(os.fspath(path))
    try:
        groups, errors = suite.run_all(ds, [CHECKER], skip_checks=[])[CHECKER]
    finally:
        ds.close()
    findings: list[str] = []
    for result in groups:
        _walk(result, "", findings)
    for check, (exc, _tb) in sorted(errors.items()):
        findings.append(f"[exception] {check}: {type(exc).__name__}: {exc}")
    return sorted(set(findings))


def cf_findings_of_files(paths: Sequence[str | os.PathLike], workers: int = 2) -> list[list[str]]:
    """`cf_findings` of each file of ``paths``, in order, from ``workers`` processes.

    The workers are spawned (a fork of a test process whose background threads hold locks
    could hang) and each loads the checker once.
    """
    workers = max(1, min(workers, len(os.sched_getaffinity(0)), len(paths)))
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        return list(pool.map(cf_findings, [os.fspath(p) for p in paths]))
