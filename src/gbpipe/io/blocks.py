"""A NetCDF file written block by block along time, with the metadata and provenance of
:func:`gbpipe.io.write`: outputs too long to hold in memory (issue 47).

:func:`gbpipe.io.write` takes a whole dataset in memory. :func:`block_writer` lets that
writer make a *template* — the dataset with any short ``time`` axis but every variable,
attribute and the provenance (gbpipe version, config hash, source files with their
SHA-256) — then creates the real file with the template's variables, attributes, types and
compression and the full time dimension, and hands the caller a :class:`BlockFile` to fill
the variables on ``time`` block by block, in any order, and to set at the end those
variables off ``time`` whose values are known only once every block has been seen (a
statistic of the whole record). The file's content is then that of :func:`gbpipe.io.write`
for the whole dataset (tested); only the HDF5 chunking along time differs.

Everything happens in a temporary file renamed onto the target only when the ``with``
block ends without an exception and every variable on ``time`` has been filled
(:func:`gbpipe.io.atomic_path`): a failure, or a variable left half filled, leaves no
output and an existing one untouched. The template is a temporary too
(:func:`gbpipe.io.atomic.scratch_path`).

The float32 and ``noisy`` storage of :func:`gbpipe.io.write` decide from the data, which
the template does not hold: a block-written variable is stored at the template's dtype.
"""

from __future__ import annotations

import os
from collections.abc import Collection, Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import netCDF4
import numpy as np
import xarray as xr

from gbpipe.io.atomic import atomic_path, scratch_path
from gbpipe.io.cf import TIME_DIM
from gbpipe.io.netcdf import write

__all__ = ["BlockFile", "block_writer", "CHUNK"]

#: HDF5 chunk along time [samples] of the block-written variables (512 kB of float64 per
#: column).
CHUNK = 1 << 16
#: Chunks of HDF5 cache per variable [-]: blocks that straddle chunk edges, written in any
#: order, complete a chunk in the cache before it is compressed (once); the netCDF default
#: (up to 64 MB per variable) would hold much of a long record until the file is closed.
_CACHE_CHUNKS = 4


class BlockFile:
    """A NetCDF file being filled (made by :func:`block_writer`; not built directly).

    Variables are named as in the template (``time`` included); the values are in the
    producer's units, as for :func:`gbpipe.io.write`.
    """

    def __init__(self, nc: netCDF4.Dataset, n_time: int, late: Collection[str]) -> None:
        self._nc, self.n_time = nc, n_time
        self._filled: dict[str, list[tuple[int, int]]] = {
            name: [] for name, var in nc.variables.items() if TIME_DIM in var.dimensions}
        self._late = set(late)
        unknown = sorted(self._late - set(nc.variables))
        if unknown:
            raise ValueError(f"late={unknown}: not variables of the template")

    def __contains__(self, name: str) -> bool:
        return name in self._nc.variables

    def _timed(self, name: str) -> netCDF4.Variable:
        if name not in self._filled:
            raise ValueError(f"{name!r} is no variable on time of this file (variables on "
                             f"time: {', '.join(self._filled)})")
        return self._nc[name]

    def write(self, name: str, start: int, values: np.ndarray) -> None:
        """Samples ``start … start + len(values) − 1`` of the variable ``name`` on time.

        Parameters
        ----------
        name : str
            A template variable whose first dimension is ``time``.
        start : int
            First sample [-].
        values : ndarray
            ``(n, *other dims)`` in the variable's unit.
        """
        var = self._timed(name)
        values = np.asarray(values)
        stop = start + len(values)
        if start < 0 or stop > self.n_time:
            raise ValueError(f"{name}: samples {start}-{stop - 1} outside the file's "
                             f"0-{self.n_time - 1}")
        var[start:stop] = values
        self._filled[name].append((start, stop))

    def read(self, name: str, start: int, stop: int) -> np.ndarray:
        """Samples ``start … stop − 1`` of the variable ``name`` on time, as written."""
        return np.asarray(self._timed(name)[start:stop])

    def set(self, name: str, values: Any) -> None:
        """The whole value of the variable ``name`` (one not on time, e.g. a statistic
        known once every block has been seen)."""
        if name in self._filled:
            raise ValueError(f"{name!r} is on time: write it with BlockFile.write")
        self._nc[name][...] = np.asarray(values)
        self._late.discard(name)

    def check_complete(self) -> None:
        """Refuse a file with a sample of a variable on time never written, or a ``late``
        variable never set.

        Raises
        ------
        ValueError
            Naming the variable and the first missing sample.
        """
        for name, spans in self._filled.items():
            reached = 0
            for a, b in sorted(spans):
                if a > reached:
                    break
                reached = max(reached, b)
            if reached < self.n_time:
                raise ValueError(f"{name}: sample {reached} (of {self.n_time}) never "
                                 "written; the file is not kept")
        if self._late:
            raise ValueError(f"{', '.join(sorted(self._late))}: never set; the file is "
                             "not kept")


def _expand(src: netCDF4.Dataset, dst: netCDF4.Dataset, n_time: int) -> None:
    """Copy ``src`` into ``dst`` with the time dimension ``n_time`` long; the data of the
    variables off time too."""
    src.set_auto_maskandscale(False)
    dst.set_auto_maskandscale(False)
    dst.setncatts({k: src.getncattr(k) for k in src.ncattrs()})
    for name, dim in src.dimensions.items():
        dst.createDimension(name, n_time if name == TIME_DIM else len(dim))
    for name, var in src.variables.items():
        attrs = {k: var.getncattr(k) for k in var.ncattrs()}
        filters = var.filters() or {}
        timed = TIME_DIM in var.dimensions
        if timed and var.dimensions[0] != TIME_DIM:
            raise ValueError(f"{name}: time must be the first dimension of a block-written "
                             f"variable (dimensions {var.dimensions})")
        chunks = ([min(n_time, CHUNK) if d == TIME_DIM else max(len(src.dimensions[d]), 1)
                   for d in var.dimensions] if timed else None)
        new = dst.createVariable(
            name, var.datatype, var.dimensions, zlib=bool(filters.get("zlib")),
            complevel=filters.get("complevel", 4), shuffle=bool(filters.get("shuffle")),
            fill_value=attrs.pop("_FillValue", False), chunksizes=chunks)
        new.setncatts(attrs)
        if timed:
            size = int(np.prod(chunks)) * np.dtype(var.dtype).itemsize
            new.set_var_chunk_cache(size=_CACHE_CHUNKS * size, nelems=521, preemption=1.0)
        else:
            new[...] = var[...]


@contextmanager
def block_writer(template: xr.Dataset, n_time: int, path: str | os.PathLike, *,
                 stage: str, late: Collection[str] = (), config: Any = None,
                 wildcards: Mapping[str, Any] | None = None,
                 sources: Iterable[str | os.PathLike] = (), title: str | None = None
                 ) -> Iterator[BlockFile]:
    """Write the dataset ``template`` describes with a time axis of ``n_time`` samples,
    filled block by block (module docstring).

    Parameters
    ----------
    template : xarray.Dataset
        Every variable and attribute of the output, with any short ``time`` axis (the
        variables on it with ``time`` as their first dimension). What :func:`gbpipe.io.write`
        requires of a dataset (``units`` and ``long_name`` everywhere) holds for it.
    n_time : int
        Length of the output's time axis [samples].
    path : path-like
        Target file, replaced only when the new one is complete.
    stage, config, wildcards, sources, title
        The provenance, as for :func:`gbpipe.io.write`.
    late : collection of str
        Variables off time whose template values are placeholders: each must be given
        with :meth:`BlockFile.set` before the ``with`` block ends.

    Yields
    ------
    BlockFile
        Write every variable on time (``time`` included) with :meth:`BlockFile.write`.

    Raises
    ------
    ValueError
        A variable on time not filled, or a ``late`` one not set (no file is kept); what
        :func:`gbpipe.io.write` refuses in the template.
    """
    path = Path(path)
    with atomic_path(path) as tmp, scratch_path(path, "template.") as small:
        write(template, small, stage=stage, config=config, wildcards=wildcards,
              sources=sources, title=title)
        with netCDF4.Dataset(small) as src, netCDF4.Dataset(tmp, "w",
                                                             format="NETCDF4") as dst:
            _expand(src, dst, n_time)
            out = BlockFile(dst, n_time, late)
            yield out
            out.check_complete()
