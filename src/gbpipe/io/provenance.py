"""Provenance of an output: gbpipe version, config hash, source files with their SHA-256."""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from gbpipe import __version__

__all__ = ["config_sha256", "file_sha256", "source_files", "jsonable", "__version__"]

_BLOCK = 1 << 20  # bytes read per hash update: bounded memory for multi-GB bench files


def jsonable(obj: Any) -> Any:
    """``json.dumps`` default: numpy scalars and arrays as plain Python values."""
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"cannot store an object of type {type(obj).__name__} as JSON")


def config_sha256(config_slice: Any) -> str:
    """SHA-256 of a config slice in canonical JSON (sorted keys, no spaces).

    Parameters
    ----------
    config_slice : object
        Any JSON-serialisable value (dict, list, number, string).

    Returns
    -------
    str
        64 hexadecimal digits.
    """
    text = json.dumps(config_slice, sort_keys=True, separators=(",", ":"), default=jsonable)
    return hashlib.sha256(text.encode()).hexdigest()


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes, read in 1 MiB blocks."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while block := fh.read(_BLOCK):
            h.update(block)
    return h.hexdigest()


def source_files(paths: Iterable[str | os.PathLike]) -> list[dict[str, Any]]:
    """Name, size [bytes] and SHA-256 of each existing input file, in the given order.

    Directories and missing paths are skipped (a rule's inputs may name code folders).
    """
    out = []
    for p in paths:
        path = Path(p)
        if path.is_file():
            out.append({"path": str(p), "bytes": path.stat().st_size,
                        "sha256": file_sha256(path)})
    return out
