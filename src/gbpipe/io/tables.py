"""CSV tables, written atomically with the usual permissions."""

from __future__ import annotations

import csv
import os
from pathlib import Path

from gbpipe.io.atomic import atomic_path

__all__ = ["write_csv"]


def write_csv(rows: list[dict], path: str | os.PathLike) -> Path:
    """Write rows (dicts) to CSV atomically, columns in first-seen order.

    Parameters
    ----------
    rows : list of dict
        One dict per row; a key missing from a row leaves its cell empty.
    path : path-like
        The CSV file (mode 0644 under the usual umask).

    Returns
    -------
    pathlib.Path
    """
    path = Path(path)
    cols: list[str] = []
    for r in rows:
        cols += [k for k in r if k not in cols]
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=cols)
        w.writeheader()
        w.writerows(rows)
    return path
