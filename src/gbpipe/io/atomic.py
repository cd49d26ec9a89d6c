"""Atomic output files: write to a temporary beside the target, then rename.

Every file a stage writes (NetCDF, CSV, figures, captions) goes through
:func:`atomic_path`, so that

* a failed or killed job never leaves a half-written output, nor clobbers an old one;
* the output gets the usual permissions (``0666 & ~umask``, i.e. 0644), never the 0600 of
  :func:`tempfile.mkstemp`;
* every temporary has one recognisable name, ``.<name>.<random>.tmp``, so that
  :func:`clean_temporaries` can remove what a job killed with SIGKILL left behind (the
  workflow calls it when it starts).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_path", "scratch_path", "clean_temporaries", "output_mode", "TEMP_GLOB"]

#: Glob of the temporaries :func:`atomic_path` makes (hidden, ``.tmp`` suffix).
TEMP_GLOB = ".*.gbpipe.tmp"


def output_mode() -> int:
    """Permission bits of a new output: ``0o666 & ~umask`` (0644 under the usual umask)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextmanager
def scratch_path(path: str | os.PathLike, tag: str = "") -> Iterator[Path]:
    """Yield a new empty temporary file beside ``path`` (named as :data:`TEMP_GLOB` says,
    ``tag`` in its name), removed when the ``with`` block ends.

    For a file a job needs only while it writes ``path`` (the template of
    :func:`gbpipe.io.block_writer`): a job killed with SIGKILL leaves it to
    :func:`clean_temporaries`. The folder is created if needed.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{tag}", suffix=".gbpipe.tmp",
                               dir=path.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
    finally:
        tmp_path.unlink(missing_ok=True)


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it onto ``path``.

    The caller writes the temporary (with any library: netCDF4, matplotlib, csv); when the
    ``with`` block ends without an exception the file gets :func:`output_mode` and replaces
    ``path`` in one rename. On an exception the temporary is removed and ``path`` is left
    as it was.

    Parameters
    ----------
    path : path-like
        The final output. Its folder is created if needed.
    """
    with scratch_path(path) as tmp_path:
        yield tmp_path
        os.chmod(tmp_path, output_mode())
        os.replace(tmp_path, path)


def clean_temporaries(root: str | os.PathLike) -> list[Path]:
    """Remove the temporaries that killed jobs left under ``root``; return them.

    Only files matching :data:`TEMP_GLOB` are touched, so no output is ever removed. Call it
    when no job is writing (the workflow's ``onstart``).
    """
    root = Path(root)
    if not root.is_dir():
        return []
    stale = sorted(root.rglob(TEMP_GLOB))
    for p in stale:
        p.unlink(missing_ok=True)
    return stale
