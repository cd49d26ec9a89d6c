"""The one NetCDF reader and writer of gbpipe.

Every stage writes through :func:`write`, which

* refuses a variable or coordinate without ``units`` and ``long_name``;
* adds the provenance attributes of the data contract (``gbpipe_version``,
  ``config_sha256`` of the stage's config slice, ``created``, ``stage``, wildcard values)
  and the CF-1.11 globals (``Conventions``, ``title``, ``source``, ``history``);
* stores the relative ``time`` axis the CF way (``seconds since`` an arbitrary epoch,
  ``axis: T``) and :func:`read` turns it back into plain seconds;
* writes to a temporary file in the target folder and renames it, so that a failed
  stage never leaves a half-written output.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from gbpipe import __version__

__all__ = ["write", "read", "config_sha256", "TIME_EPOCH"]

#: Epoch of the CF encoding of relative time axes. A record's t = 0 is its start; the
#: epoch is only there because CF wants a reference date for a ``time`` coordinate.
TIME_EPOCH = "2000-01-01 00:00:00"
_TIME_UNITS = f"seconds since {TIME_EPOCH}"


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
    text = json.dumps(config_slice, sort_keys=True, separators=(",", ":"), default=_jsonable)
    return hashlib.sha256(text.encode()).hexdigest()


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"cannot hash object of type {type(obj).__name__} in a config slice")


def _check_metadata(ds: xr.Dataset) -> None:
    missing = [
        f"{name} ({', '.join(k for k in ('units', 'long_name') if k not in var.attrs)})"
        for name, var in {**ds.coords, **ds.data_vars}.items()
        if not {"units", "long_name"} <= set(var.attrs)
    ]
    if missing:
        raise ValueError(
            "every NetCDF variable needs 'units' and 'long_name' attributes; missing on: "
            + "; ".join(missing)
        )


def _attr_value(value: Any) -> Any:
    # NetCDF attributes take strings and numbers; anything else is stored as JSON text.
    if isinstance(value, str | int | float | np.number):
        return value
    if isinstance(value, bool):
        return int(value)
    return json.dumps(value, default=_jsonable)


def write(
    ds: xr.Dataset,
    path: str | os.PathLike,
    *,
    stage: str,
    config: Any = None,
    wildcards: Mapping[str, Any] | None = None,
    title: str | None = None,
    float32: bool = False,
) -> Path:
    """Write a dataset as CF-1.11 NetCDF-4 with provenance, atomically.

    Parameters
    ----------
    ds : xarray.Dataset
        Every data variable and coordinate must carry ``units`` and ``long_name``.
        A coordinate named ``time`` is taken as seconds from the record start.
    path : path-like
        Target file; its folder is created if needed.
    stage : str
        Name of the workflow stage that made the data.
    config : object, optional
        The config slice the stage depends on; its SHA-256 is stored.
    wildcards : mapping, optional
        Wildcard values of the job, stored as ``wildcard_<name>`` attributes.
    title : str, optional
        Human-readable title; defaults to ``"gbpipe <stage>"``.
    float32 : bool, default False
        Store float64 data variables as float32 (coordinates stay float64).

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    ValueError
        If a variable lacks ``units`` or ``long_name``.
    """
    _check_metadata(ds)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = ds.copy()
    now = _dt.datetime.now(_dt.UTC).replace(microsecond=0).isoformat()
    history = out.attrs.get("history", "")
    out.attrs.update(
        {
            "Conventions": "CF-1.11",
            "title": title or out.attrs.get("title", f"gbpipe {stage}"),
            "institution": out.attrs.get("institution", "gbpipe"),
            "source": f"gbpipe {__version__} stage '{stage}'",
            "history": (history + "\n" if history else "") + f"{now}: gbpipe {stage}",
            "references": "Torque measurements from MW wind turbine gearboxes: "
            "a system identification approach",
            "gbpipe_version": __version__,
            "stage": stage,
            "config_sha256": config_sha256(config if config is not None else {}),
            "created": now,
        }
    )
    for key, value in (wildcards or {}).items():
        out.attrs[f"wildcard_{key}"] = str(value)
    out.attrs = {k: _attr_value(v) for k, v in out.attrs.items()}
    if "time" in out.coords:
        out["time"].attrs.update(
            {"units": _TIME_UNITS, "standard_name": "time", "calendar": "standard", "axis": "T"}
        )
    for name in out.variables:
        out[name].attrs = {k: _attr_value(v) for k, v in out[name].attrs.items()}
    encoding: dict[str, dict[str, Any]] = {}
    for name, var in out.variables.items():
        enc: dict[str, Any] = {}
        if name in out.coords:
            enc["_FillValue"] = None
        elif var.dtype.kind in "fc":
            enc.update(zlib=True, complevel=4)
            if float32 and var.dtype == np.float64:
                enc["dtype"] = "float32"
        elif var.dtype.kind in "iub":
            enc.update(zlib=True, complevel=4)
        if var.dtype.kind in "iub" or var.dtype.kind in "US" or var.dtype == object:
            enc["_FillValue"] = None
        encoding[name] = enc
    fd, tmp = tempfile.mkstemp(suffix=".nc.tmp", dir=path.parent)
    os.close(fd)
    try:
        out.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def read(path: str | os.PathLike) -> xr.Dataset:
    """Read a gbpipe NetCDF file fully into memory.

    The relative ``time`` axis comes back as float seconds with ``units: s``.

    Parameters
    ----------
    path : path-like
        A file written by :func:`write`.

    Returns
    -------
    xarray.Dataset
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no NetCDF file at {path}: run the stage that makes it first")
    with xr.open_dataset(path, engine="netcdf4", decode_times=False) as ds:
        ds = ds.load()
    if "time" in ds.coords and str(ds["time"].attrs.get("units", "")).startswith("seconds since"):
        ds["time"].attrs["units"] = "s"
        for key in ("standard_name", "calendar", "axis"):
            ds["time"].attrs.pop(key, None)
    return ds
