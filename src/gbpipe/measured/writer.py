"""A record written to NetCDF block by block, with the metadata and provenance of
:func:`gbpipe.io.write`.

:func:`gbpipe.io.write` takes a whole dataset in memory. A long record does not fit, so
:func:`write_blocks` lets that writer make a *template* — the record with a two-sample
time axis but every variable, attribute and the provenance (gbpipe version, config hash,
source files with their SHA-256) — then creates the real file with the template's
variables, attributes, types and compression, and the full time dimension, and lets the
caller fill the time axis block by block. Everything happens in a temporary file renamed
onto the target at the end (:func:`gbpipe.io.atomic_path`): a failure leaves nothing.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import netCDF4
import xarray as xr

from gbpipe.io import atomic_path, write
from gbpipe.io.cf import TIME_DIM, decode

__all__ = ["write_blocks", "write_dataset", "open_record", "CHUNK", "INDEX_LIMIT"]

#: HDF5 chunk along time [samples] of the streamed variables (512 kB of float64)
CHUNK = 1 << 16
_CACHE = 4 * 8 * CHUNK  # bytes of HDF5 chunk cache per variable (4 chunks)
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
                 fill: Callable[[netCDF4.Dataset], None],
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
        Target file.
    fill : callable
        ``fill(nc)`` writes every variable on ``time`` of the open :class:`netCDF4.Dataset`
        (e.g. ``nc["torque"][a:b] = block``), in its producer's units.
    provenance : mapping, optional
        Keyword arguments of :func:`gbpipe.io.write` (``stage``, ``config``,
        ``wildcards``, ``sources``, ``title``).
    sources : iterable of path-like
        The record's files (name, size and SHA-256 stored).
    """
    out = Path(out)
    with atomic_path(out) as tmp, tempfile.TemporaryDirectory(dir=out.parent) as folder:
        small = Path(folder) / "template.nc"
        write(template, small, **_write_kwargs(provenance, sources))
        with netCDF4.Dataset(small) as src, netCDF4.Dataset(tmp, "w",
                                                             format="NETCDF4") as dst:
            _expand(src, dst, n_time)
            fill(dst)
    return out


def _expand(src: netCDF4.Dataset, dst: netCDF4.Dataset, n_time: int) -> None:
    """Copy ``src`` into ``dst`` with the ``time`` dimension ``n_time`` long; the data of
    variables without ``time`` too."""
    src.set_auto_maskandscale(False)
    dst.set_auto_maskandscale(False)
    dst.setncatts({k: src.getncattr(k) for k in src.ncattrs()})
    for name, dim in src.dimensions.items():
        dst.createDimension(name, n_time if name == TIME_DIM else len(dim))
    for name, var in src.variables.items():
        attrs = {k: var.getncattr(k) for k in var.ncattrs()}
        filters = var.filters() or {}
        timed = TIME_DIM in var.dimensions
        new = dst.createVariable(
            name, var.datatype, var.dimensions, zlib=bool(filters.get("zlib")),
            complevel=filters.get("complevel", 4), shuffle=bool(filters.get("shuffle")),
            fill_value=attrs.pop("_FillValue", False),
            chunksizes=[min(n_time, CHUNK) if d == TIME_DIM else len(src.dimensions[d])
                        for d in var.dimensions] if timed else None)
        new.setncatts(attrs)
        if timed:
            # Blocks are written in order, chunk after chunk: a small cache suffices, and
            # the netCDF default (up to 64 MB per variable) would hold much of a long
            # record until the file is closed.
            new.set_var_chunk_cache(size=_CACHE, nelems=521, preemption=1.0)
        else:
            new[...] = var[...]


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
