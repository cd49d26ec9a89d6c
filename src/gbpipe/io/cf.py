"""CF-1.11 encoding and decoding of gbpipe datasets (used by :mod:`gbpipe.io.netcdf`).

Every stage writes through :func:`write`, which

* refuses a variable or coordinate without ``units`` and ``long_name``;
* adds the provenance attributes of the data contract (``gbpipe_version``,
  ``config_sha256`` of the stage's config slice, ``created``, ``stage``, wildcard values)
  and the CF-1.11 globals (``Conventions``, ``title``, ``institution``, ``source``,
  ``history``, ``references``);
* stores the relative ``time`` axis the CF way and :func:`read` turns it back into plain
  seconds;
* writes to a temporary file in the target folder and renames it, so that a failed
  stage never leaves a half-written output, nor clobbers an existing one.

The files pass ``compliance-checker --test=cf:1.11`` with no finding of any priority.
:func:`write` gets there *generically*, never by knowing a stage; :func:`read` undoes each
step, so that ``read(write(ds))`` gives back the producer's names, units and attributes.

CF representation choices
-------------------------
Relative time
    A coordinate named ``time`` must hold seconds from the record start (``units: s``).
    It is stored as ``seconds since 2000-01-01 00:00:00`` (:data:`TIME_EPOCH`, arbitrary:
    CF wants a reference date) with ``standard_name: time``, ``calendar: standard``,
    ``axis: T`` and ``units_metadata: "leap_seconds: none"`` — a simulation or logger
    clock counts SI seconds and never inserts leap seconds.
Labelled dimensions
    CF (§1.3, after the NUG) defines a coordinate variable — one named like its
    dimension — as *numeric and strictly monotonic*. A dimension coordinate that is not
    (string labels such as state or shaft names, or unsorted numbers) is stored as the
    auxiliary coordinate ``<dim>_label`` (CF §6.1 "labels"), listed in the
    ``coordinates`` attribute of the variables on that dimension and marked
    ``gbpipe_labels_of: <dim>``; :func:`read` makes it the dimension coordinate again.
Units
    ``units`` must parse with UDUNITS-2. Our own spellings are mapped word by word
    (``rev`` -> ``revolution``, ``deg`` -> ``degree``, ``Nm`` -> ``N m``). Two kinds of
    quantity have no UDUNITS unit and are stored with ``units: "1"``, a ``comment`` that
    says so, and the producer's string kept in ``gbpipe_units`` (restored by :func:`read`):

    * levels in decibels (``dB``: 20 log10 of a magnitude ratio) — UDUNITS has no
      logarithmic units;
    * arrays whose elements have different units (``mixed (see ...)``, e.g. the
      state-space matrices that mix rad, rad/s and N·m): CF has one unit per variable.
      The per-row and per-column units are stored beside them as string coordinates
      (``state_units``, ``input_units``, ``output_units``), so nothing is lost; ``"1"``
      is a placeholder there, not a claim that the elements are dimensionless, and the
      comment says exactly that.
Encoding
    NetCDF-4 (HDF5), uncompressed: the bulk of every output is noise-like float time series,
    which zlib (level 4, shuffle) shrank by 30 % (a converted bench record) to 38 % (a
    simulated record) at 20 s of the full run's 160 s of CPU and 83 % of a bench-record
    conversion's time (docs/measured.md). No ``_FillValue`` on coordinates
    (CF forbids missing coordinate values), on integers or on strings; strings as
    NetCDF-4 ``string`` (allowed since CF-1.9). The in-memory ``encoding`` of the input
    (e.g. left over from a file it was read from) is ignored: this writer alone decides
    the on-disk form.
"""

from __future__ import annotations

import json
import re
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.io.provenance import jsonable

__all__ = ["TIME_EPOCH", "cf_units", "check_metadata", "encode", "decode", "encoding",
           "attr_value", "append_line"]

#: Epoch of the CF encoding of relative time axes. A record's t = 0 is its start; the
#: epoch is only there because CF wants a reference date for a ``time`` coordinate.
TIME_EPOCH = "2000-01-01 00:00:00"
_TIME_UNITS = f"seconds since {TIME_EPOCH}"
_TIME_ATTRS = {
    "units": _TIME_UNITS,
    "standard_name": "time",
    "calendar": "standard",
    "axis": "T",
    "units_metadata": "leap_seconds: none",
}
# Spellings of "seconds" a producer may give the relative time axis.
_SECONDS = {"s", "second", "seconds", "sec"}

# Whole words of our unit strings that UDUNITS-2 does not know, and its word for them.
_UNIT_WORDS = {"rev": "revolution", "revs": "revolution", "deg": "degree",
               "degs": "degree", "Nm": "N m"}
_UNIT_WORD = re.compile(r"[A-Za-z]+")

# Attribute names this module adds to variables (and :func:`read` removes again).
_LABELS_OF = "gbpipe_labels_of"
_ORIGINAL_UNITS = "gbpipe_units"
_LABEL_SUFFIX = "_label"


def cf_units(units: str) -> tuple[str, str | None]:
    """The UDUNITS-2 form of one of our unit strings, and why it differs if it must.

    Parameters
    ----------
    units : str
        A producer's ``units`` attribute, e.g. ``"rev/min"``, ``"dB"``,
        ``"mixed (see state_units)"``, ``"N m"``.

    Returns
    -------
    cf : str
        A UDUNITS-2 string: the same quantity respelled, or ``"1"`` for decibels and
        for mixed units, which UDUNITS cannot express.
    note : str or None
        For ``"1"`` placeholders, the sentence :func:`write` adds to ``comment``.
    """
    text = str(units).strip()
    if text.lower().startswith("mixed"):
        return "1", (
            f"units: the elements of this array have different units ({text}); CF allows "
            "one unit per variable, so units is '1' as a placeholder, not a claim that the "
            "values are dimensionless.")
    if re.match(r"dB(?![A-Za-z])", text):
        return "1", (
            f"units: the values are levels in decibels ({text}), a logarithmic scale that "
            "UDUNITS cannot express, so units is '1'.")
    return _UNIT_WORD.sub(lambda m: _UNIT_WORDS.get(m.group(), m.group()), text), None


def check_metadata(ds: xr.Dataset) -> None:
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
    if "time" in ds.coords and str(ds["time"].attrs["units"]).strip() not in _SECONDS:
        raise ValueError(
            f"coordinate 'time' must be seconds from the record start (units 's'); got "
            f"units {ds['time'].attrs['units']!r}: convert it to seconds first")
    for dim in ds.dims:
        label = f"{dim}{_LABEL_SUFFIX}"
        if dim in ds.coords and not is_cf_coordinate(ds[dim]) and label in ds.variables:
            raise ValueError(
                f"dimension coordinate {dim!r} is not numeric and strictly monotonic, so it "
                f"is stored as the CF label variable {label!r}, but the dataset already has "
                f"a variable {label!r}: rename that variable")


def is_cf_coordinate(var: xr.DataArray) -> bool:
    # CF §1.3: a coordinate variable is numeric, strictly monotonic, without missing values.
    # Datetimes and timedeltas are encoded to numbers by xarray and are left to it.
    if var.dtype.kind in "mM":
        return True
    if var.dtype.kind not in "iuf":
        return False
    values = np.asarray(var.values)
    if values.ndim != 1 or not np.all(np.isfinite(values)):
        return False
    step = np.diff(values)
    return bool(np.all(step > 0) or np.all(step < 0))


def attr_value(value: Any) -> Any:
    # NetCDF attributes take strings and numbers; anything else is stored as JSON text.
    if isinstance(value, bool | np.bool_):
        return int(value)
    if isinstance(value, str | int | float | np.number):
        return value
    return json.dumps(value, default=jsonable)


def append_line(text: str | None, line: str) -> str:
    return f"{text}\n{line}" if text else line


def encode(out: xr.Dataset) -> xr.Dataset:
    """Units, time axis and labelled dimensions in their CF form (see module docstring)."""
    for name in out.variables:
        attrs = {k: attr_value(v) for k, v in out[name].attrs.items()}
        if name == "time" and name in out.coords:
            attrs.update(_TIME_ATTRS)
        else:
            units, note = cf_units(attrs["units"]) if "units" in attrs else (None, None)
            if units is not None and units != attrs["units"]:
                attrs[_ORIGINAL_UNITS] = attrs["units"]
                attrs["units"] = units
            if note:
                attrs["comment"] = append_line(attrs.get("comment"), note)
        out[name].attrs = attrs
    for dim in list(out.dims):
        if dim in out.coords and not is_cf_coordinate(out[dim]):
            coord = out[dim]
            attrs = {**coord.attrs, _LABELS_OF: dim}
            out = out.drop_vars(dim).assign_coords(
                {f"{dim}{_LABEL_SUFFIX}": (dim, coord.values, attrs)})
    return out


def encoding(out: xr.Dataset, float32: bool) -> dict[str, dict[str, Any]]:
    encoding: dict[str, dict[str, Any]] = {}
    for name, var in out.variables.items():
        enc: dict[str, Any] = {}
        if name in out.coords:
            enc["_FillValue"] = None
        elif var.dtype.kind in "fc" and float32 and var.dtype == np.float64:
            enc["dtype"] = "float32"
        if var.dtype.kind in "iubUS" or var.dtype == object:
            enc["_FillValue"] = None
        encoding[name] = enc
    return encoding




def decode(ds: xr.Dataset) -> xr.Dataset:
    """Undo :func:`encode`: producer units, labelled dimensions, time in plain seconds."""
    for name in list(ds.variables):
        attrs = dict(ds[name].attrs)
        if _ORIGINAL_UNITS in attrs:
            _, note = cf_units(attrs[_ORIGINAL_UNITS])
            attrs["units"] = attrs.pop(_ORIGINAL_UNITS)
            if note and "comment" in attrs:
                comment = attrs["comment"].replace(note, "").rstrip("\n")
                if comment:
                    attrs["comment"] = comment
                else:
                    del attrs["comment"]
        ds[name].attrs = attrs
        ds[name].encoding.pop("coordinates", None)
    for name in list(ds.variables):
        if _LABELS_OF in ds[name].attrs:
            label = ds[name]
            dim = label.attrs[_LABELS_OF]
            attrs = {k: v for k, v in label.attrs.items() if k != _LABELS_OF}
            ds = ds.drop_vars(name).assign_coords({dim: (dim, label.values, attrs)})
    if "time" in ds.coords and str(ds["time"].attrs.get("units", "")).startswith("seconds since"):
        ds["time"].attrs["units"] = "s"
        for key in ("standard_name", "calendar", "axis", "units_metadata"):
            ds["time"].attrs.pop(key, None)
    return ds
