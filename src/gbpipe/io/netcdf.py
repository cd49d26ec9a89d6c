"""The one NetCDF reader and writer of gbpipe.

Every stage writes through :func:`write`, which refuses a variable without ``units`` and
``long_name``, adds the provenance of the data contract (``docs/architecture.md``, "Data
contract": gbpipe version, config hash, source files with their SHA-256, wildcards) and
the CF-1.11 globals, encodes the dataset the CF way (:mod:`gbpipe.io.cf`) and writes it
atomically (:mod:`gbpipe.io.atomic`), each variable compressed and at the precision
:mod:`gbpipe.io.storage` chooses. :func:`read` undoes the encoding.
"""

from __future__ import annotations

import json
import os
from collections.abc import Collection, Iterable, Mapping
from pathlib import Path
from typing import Any

import netCDF4
import xarray as xr

from gbpipe.io.atomic import atomic_path
from gbpipe.io.cf import TIME_DIM, append_line, attr_value, check_metadata, decode, encode
from gbpipe.io.provenance import __version__, config_sha256, jsonable, source_files
from gbpipe.io.storage import storage

__all__ = ["write", "read"]


def write(
    ds: xr.Dataset,
    path: str | os.PathLike,
    *,
    stage: str,
    config: Any = None,
    wildcards: Mapping[str, Any] | None = None,
    sources: Iterable[str | os.PathLike] = (),
    title: str | None = None,
    float32: bool = False,
    noisy: Collection[str] = (),
) -> Path:
    """Write a dataset as CF-1.11 NetCDF-4 with provenance, atomically.

    Parameters
    ----------
    ds : xarray.Dataset
        Every data variable and coordinate must carry ``units`` and ``long_name``.
        A coordinate named ``time`` is taken as seconds from the record start and must
        have ``units: s``. Not modified.
    path : path-like
        Target file; its folder is created if needed. An existing file is replaced only
        once the new one is complete.
    stage : str
        Name of the workflow stage that made the data.
    config : object, optional
        The config slice the stage depends on; its SHA-256 is stored as ``config_sha256``
        and the slice itself as JSON in ``config``.
    wildcards : mapping, optional
        Wildcard values of the job, stored as ``wildcard_<name>`` attributes.
    sources : iterable of path-like, optional
        The files the data came from (a rule's inputs, a bench file): name, size and
        SHA-256 of each are stored as JSON in ``source_files``.
    title : str, optional
        Human-readable title; defaults to the dataset's ``title`` or ``"gbpipe <stage>"``.
    float32 : bool, default False
        Store every float64 data variable as float32 (coordinates stay float64): for
        stages whose data need no more. Each such variable's ``comment`` says what
        rounding cost.
    noisy : collection of str, optional
        Measured(-like) time series (data variables on ``time``): each is stored as
        float32 where its rounding error lies at least
        :data:`gbpipe.io.storage.MARGIN_DB` below the series' own power spectral density
        at every frequency (its noise floor leaves room), else as float64, and is
        rounded to the largest power-of-two step whose rounding lies that far under its
        noise floor (:func:`gbpipe.io.storage.quantum`); its ``comment`` says the step,
        the error and the margin. Also under ``float32``. Never
        name a series that another computation compares exactly (a noise-free reference).

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    ValueError
        If a variable lacks ``units`` or ``long_name``, if ``time`` is not in seconds, if
        a labelled dimension's ``<dim>_label`` name or the time dimension's on-disk name
        is already taken, or if ``noisy`` names a variable not on ``time``.
    """
    check_metadata(ds)
    path = Path(path)
    out = ds.copy()
    # Encodings left over from a file the data came from would override ours (and may
    # name coordinates that no longer exist): this writer alone decides the on-disk form.
    out.encoding = {}
    for var in out.variables.values():
        var.encoding = {}
    cfg = config if config is not None else {}
    out.attrs.update(
        {
            "Conventions": "CF-1.11",
            "title": title or out.attrs.get("title", f"gbpipe {stage}"),
            "institution": out.attrs.get("institution", "gbpipe"),
            "source": f"gbpipe {__version__} stage '{stage}'",
            # no clock time: the same config and inputs give the same bytes (a rerun is
            # told from the first run by nothing; the job logs say when)
            "history": append_line(out.attrs.get("history"), f"gbpipe {__version__} {stage}"),
            "references": "Torque measurements from MW wind turbine gearboxes: "
            "a system identification approach",
            "gbpipe_version": __version__,
            "stage": stage,
            "config_sha256": config_sha256(cfg),
            "config": json.dumps(cfg, sort_keys=True, default=jsonable),
            "source_files": json.dumps(source_files(sources)),
        }
    )
    for key, value in (wildcards or {}).items():
        out.attrs[f"wildcard_{key}"] = str(value)
    out.attrs = {k: attr_value(v) for k, v in out.attrs.items()}
    out, enc = storage(encode(out), float32, set(noisy), TIME_DIM)
    with atomic_path(path) as tmp:
        out.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=enc)
    return path


#: HDF5 chunk cache of every variable of a file opened after gbpipe.io [bytes]. The
#: netCDF library's default, 64 MiB per variable, is kept while a file is open: an identify
#: job with a 20-min bench record and its TSA version open (lazily, 14 variables) held
#: 0.9 GB of it. A variable is read whole and in order (or in windows of whole chunks of
#: 512 kB, gbpipe.io.blocks.CHUNK), so two chunks are enough: 569 -> 387 MB peak
#: for the identify job of a 6-min record (4 MiB: 427 MB), the same CPU time (23.8, 23.6 s).
READ_CACHE = 1 << 20
netCDF4.set_chunk_cache(READ_CACHE, 1009, 0.75)


def read(path: str | os.PathLike, lazy: bool = False) -> xr.Dataset:
    """Read a gbpipe NetCDF file into memory, undoing the CF encoding of :func:`write`.

    The relative ``time`` axis comes back as the dimension ``time`` (float seconds,
    ``units: s``; on disk it is a coordinate of :data:`gbpipe.io.cf.TIME_DIM`); labelled
    dimensions get their string (or unsorted) coordinate back; units that :func:`write`
    had to respell or replace come back as the producer wrote them.

    Parameters
    ----------
    path : path-like
        A file written by :func:`write`.
    lazy : bool
        Read a variable from the file each time its values are used (nothing is kept),
        not all at once; the file stays open while the dataset lives. A stage that uses a
        few signals of an hour-long record (1.3 GB for 9 channels at 5 kHz) holds only its
        working copies (xarray's cache would keep every slice it was asked for).

    Returns
    -------
    xarray.Dataset

    Raises
    ------
    FileNotFoundError
        If there is no file at ``path``.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no NetCDF file at {path}: run the stage that makes it first")
    ds = xr.open_dataset(path, engine="netcdf4", decode_times=False, cache=not lazy)
    if not lazy:
        with ds:
            ds.load()
    return decode(ds)
