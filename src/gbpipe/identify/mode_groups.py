"""The repeats of one test: one row per mode of the group, with its spread over records.

A structural mode is a property of the bench: every repeat of a test shows it, at nearly
the same frequency and damping. A pole fitted to noise is not repeatable. So the per-record
clusters (:func:`gbpipe.identify.modes_table_rows`) of the records of one ``group:`` are
matched by frequency (per pairing and method, within the stabilization diagram's
``frequency_tolerance``, one cluster per record), and each match becomes one row:

* ``harmonic`` when any record calls it a line (each line test is positive evidence at
  a false-alarm probability of :data:`gbpipe.identify.mode_kinds.ALPHA`);
* else ``mode`` when at least half the records of the group call it a mode;
* else ``spurious`` (found in too few records, or noise in most).

The frequency and damping are the means over the records; the spreads are their standard
deviations over the records (one record: its cluster's spread over model orders).
docs/modal.md, "Repeats".
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["GROUP_COLUMNS", "group_table_rows"]

#: Columns of ``tables/modes_measured_groups.csv``, in order.
GROUP_COLUMNS = ("group", "pairing", "method", "frequency_hz", "damping",
                 "frequency_spread_hz", "damping_spread", "n_records", "records", "kind",
                 "evidence")


def _matches(rows: list[dict[str, Any]], tolerance: float) -> list[list[dict[str, Any]]]:
    # rows ascending in frequency; a row joins the open match when within the tolerance
    # of its median and its record is not in it yet (one cluster per record)
    out: list[list[dict[str, Any]]] = []
    for r in sorted(rows, key=lambda r: r["frequency_hz"]):
        if out:
            f = float(np.median([m["frequency_hz"] for m in out[-1]]))
            if (abs(r["frequency_hz"] - f) <= tolerance * f
                    and r["record"] not in {m["record"] for m in out[-1]}):
                out[-1].append(r)
                continue
        out.append([r])
    return out


def _row(group: str, n_group: int, match: list[dict[str, Any]]) -> dict[str, Any]:
    f = np.array([m["frequency_hz"] for m in match])
    z = np.array([m["damping"] for m in match])
    kinds = [m["kind"] for m in match]
    n = len(match)
    found = f"in {n} of {n_group} records"
    if "harmonic" in kinds:
        first = match[kinds.index("harmonic")]
        kind, why = "harmonic", (f"a line in {kinds.count('harmonic')} of {n_group} records "
                                 f"({first['record']}: {first['evidence']})")
    elif 2 * kinds.count("mode") >= n_group:
        first = match[kinds.index("mode")]
        kind, why = "mode", (f"a mode in {kinds.count('mode')} of {n_group} records "
                             f"({first['record']}: {first['evidence']})")
    else:
        kind, why = "spurious", (f"found {found}, a mode in {kinds.count('mode')}: fewer "
                                 f"than half the repeats (not repeatable); "
                                 f"{match[0]['record']}: {match[0]['evidence']}")
    return {"group": group, "pairing": match[0]["pairing"], "method": match[0]["method"],
            "frequency_hz": float(f.mean()), "damping": float(z.mean()),
            "frequency_spread_hz": (float(f.std(ddof=1)) if n > 1
                                    else float(match[0]["frequency_spread_hz"])),
            "damping_spread": (float(z.std(ddof=1)) if n > 1
                               else float(match[0]["damping_spread"])),
            "n_records": n, "records": " ".join(m["record"] for m in match),
            "kind": kind, "evidence": why}


def group_table_rows(rows: Sequence[Mapping[str, Any]], groups: Mapping[str, Sequence[str]],
                     tolerance: float) -> list[dict[str, Any]]:
    """Rows of ``tables/modes_measured_groups.csv`` (:data:`GROUP_COLUMNS`).

    Parameters
    ----------
    rows : sequence of mapping
        Per-record rows (:func:`gbpipe.identify.modes_table_rows`) of every record.
    groups : mapping str -> sequence of str
        Group name -> its records (``measured.<record>.group``); a record in no group is
        a group of one under its own name.
    tolerance : float
        Largest relative frequency difference of one mode across records [1]
        (``identify.stabilization.frequency_tolerance``).

    Returns
    -------
    list of dict
        One row per matched cluster, by group, pairing, method and frequency.
    """
    member = {r: g for g, recs in groups.items() for r in recs}
    units: dict[str, list[str]] = {}
    for r in dict.fromkeys(str(row["record"]) for row in rows):
        units.setdefault(member.get(r, r), []).append(r)
    out = []
    for group, recs in units.items():
        n_group = len(groups.get(group, recs))
        mine = [dict(r) for r in rows if r["record"] in recs]
        for key in dict.fromkeys((r["pairing"], r["method"]) for r in mine):
            same = [r for r in mine if (r["pairing"], r["method"]) == key]
            out += [_row(group, n_group, m) for m in _matches(same, tolerance)]
    return out
