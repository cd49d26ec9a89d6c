"""A record written to NetCDF: whole (:func:`write_dataset`) or block by block
(:func:`write_blocks`, :func:`gbpipe.io.block_writer`), with the metadata and provenance of
:func:`gbpipe.io.write` (stage ``measured``, the record's files among the sources), and
opened lazily again (:func:`open_record`).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import netCDF4
import xarray as xr

from gbpipe.io import BlockFile, block_writer, write
from gbpipe.io.cf import TIME_DIM, decode

__all__ = ["write_blocks", "write_dataset", "open_record", "INDEX_LIMIT"]

#: longest record [samples] that :func:`open_record` gives a pandas index on ``time``
INDEX_LIMIT = 1 << 23


def _write_kwargs(provenance: Mapping[str, Any] | None,
                  sources: Iterable[str | os.PathLike]) -> dict[str, Any]:
    """Keyword arguments of :func:`gbpipe.io.write`: stage ``measured`` by default, the
    record's files first among the sources."""
    kw = {"stage": "measured", **(provenance or {})}
    kw["sources"] = list(dict.fromkeys([*map(str, sources), *map(str, kw.get("sources", ()))]))
    return kw


def write_dataset(ds: xr.Dataset, out: str | os.PathLike, provenance: Mapping[str, Any] | None,
                  sources: Iterable[str | os.PathLike]) -> Path:
    """Write a record held in memory with :func:`gbpipe.io.write` (atomically)."""
    return write(ds, out, **_write_kwargs(provenance, sources))


def write_blocks(template: xr.Dataset, n_time: int, out: str | os.PathLike,
                 fill: Callable[[BlockFile], None],
                 provenance: Mapping[str, Any] | None,
                 sources: Iterable[str | os.PathLike]) -> Path:
    """Write a record of ``n_time`` samples whose time axis ``fill`` writes block by block.

    Parameters
    ----------
    template : xarray.Dataset
        The record with any short ``time`` axis: every variable (with ``units`` and
        ``long_name``) and attribute. Variables without ``time`` are written as they are.
    n_time : int
        Length of the record's time axis [samples].
    out : path-like
        Target file (written atomically).
    fill : callable
        ``fill(f)`` writes every variable on ``time`` of the :class:`gbpipe.io.BlockFile`
        ``f`` (``f.write("torque", a, block)``), in its producer's units.
    provenance : mapping, optional
        Keyword arguments of :func:`gbpipe.io.write` (``stage``, ``config``,
        ``wildcards``, ``sources``, ``title``).
    sources : iterable of path-like
        The record's files (name, size and SHA-256 stored).
    """
    with block_writer(template, n_time, out, **_write_kwargs(provenance, sources)) as f:
        fill(f)
    return Path(out)


def open_record(path: str | os.PathLike, index_limit: int | None = None) -> xr.Dataset:
    """A record file opened lazily, its CF encoding undone (``time`` in seconds from the
    record start, the producers' units), as :func:`gbpipe.io.read` does in memory.

    Records of up to ``index_limit`` samples (default :data:`INDEX_LIMIT`) get the usual
    pandas index on ``time``; longer ones none, because xarray would load the whole axis
    to build it (about 24 bytes per sample at the peak: 1.7 GB for 2 h at 10 kHz).
    ``ds.set_xindex("time")`` builds it when it is wanted.
    """
    limit = INDEX_LIMIT if index_limit is None else index_limit
    with netCDF4.Dataset(path) as nc:
        n = len(nc.dimensions[TIME_DIM]) if TIME_DIM in nc.dimensions else 0
    return decode(xr.open_dataset(path, engine="netcdf4", decode_times=False,
                                  create_default_indexes=n <= limit), index=n <= limit)
