"""CF-1.11 encoding and decoding of gbpipe datasets (used by :mod:`gbpipe.io.netcdf`).

Every stage writes through :func:`write`, which

* refuses a variable or coordinate without ``units`` and ``long_name``;
* adds the provenance attributes of the data contract (``gbpipe_version``,
  ``config_sha256`` of the stage's config slice, ``stage``, wildcard values; no clock time)
  and the CF-1.11 globals (``Conventions``, ``title``, ``institution``, ``source``,
  ``history``, ``references``);
* stores the relative ``time`` axis as plain seconds on the dimension :data:`TIME_DIM`,
  and :func:`read` makes it the ``time`` dimension again;
* writes to a temporary file in the target folder and renames it, so that a failed
  stage never leaves a half-written output, nor clobbers an existing one.

The files pass ``compliance-checker --test=cf:1.11`` with no finding of any priority.
:func:`write` gets there *generically*, never by knowing a stage; :func:`read` undoes each
step, so that ``read(write(ds))`` gives back the producer's names, units and attributes.

CF representation choices
-------------------------
Relative time
    A coordinate named ``time`` must hold seconds from the record start (``units: s``).
    It is stored as it is: float64 seconds, ``units: s``, so that any netCDF reader
    (plain ``xarray.open_dataset`` included) gives numbers a person can compute with, not
    dates from an arbitrary epoch. The absolute start of a bench record, where its files
    know it, is the global attribute ``record_start`` (ISO 8601). A dimension named
    ``time`` is taken by CF checkers as a calendar axis (``standard_name: time``, units
    ``<unit> since <date>``), so on disk the axis is the dimension :data:`TIME_DIM` and
    ``time`` its auxiliary coordinate (CF §5), listed in the ``coordinates`` attribute of
    the variables along it; :func:`read` makes ``time`` the dimension again. A producer's
    ``axis`` and ``standard_name`` on ``time`` are not stored: they would make a reader
    expect a calendar.
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
    NetCDF-4 (HDF5); the codec and the precision of each variable are chosen by
    :mod:`gbpipe.io.storage`. No ``_FillValue`` on coordinates (CF forbids missing
    coordinate values), on integers or on strings; strings as NetCDF-4 ``string`` (allowed
    since CF-1.9). The in-memory ``encoding`` of the input (e.g. left over from a file it
    was read from) is ignored: this writer alone decides the on-disk form.
"""

from __future__ import annotations

import json
import re
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.io.provenance import jsonable

__all__ = ["TIME_DIM", "cf_units", "check_metadata", "encode", "decode", "attr_value",
           "append_line"]

#: On-disk name of the dimension of the relative time axis (``time`` is its auxiliary
#: coordinate there; see "Relative time" above).
TIME_DIM = "sample"
# Attributes of a producer's time axis that would make a CF reader expect a calendar.
_CALENDAR_ATTRS = ("axis", "standard_name", "calendar", "units_metadata")
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
    if "time" in ds.dims and (TIME_DIM in ds.variables or TIME_DIM in ds.dims):
        raise ValueError(
            f"the time axis is stored on the dimension {TIME_DIM!r}, but the dataset already "
            f"has a dimension or variable {TIME_DIM!r}: rename it")
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
            attrs = {k: v for k, v in attrs.items() if k not in _CALENDAR_ATTRS}
            attrs["units"] = "s"  # the spelling of _SECONDS every reader knows
        else:
            units, note = cf_units(attrs["units"]) if "units" in attrs else (None, None)
            if units is not None and units != attrs["units"]:
                attrs[_ORIGINAL_UNITS] = attrs["units"]
                attrs["units"] = units
            if note:
                attrs["comment"] = append_line(attrs.get("comment"), note)
        out[name].attrs = attrs
    if "time" in out.coords and out["time"].dims == ("time",):
        # before the labels: on disk, time is no coordinate variable and need not be sorted
        out = out.swap_dims({"time": TIME_DIM})
    for dim in list(out.dims):
        if dim in out.coords and not is_cf_coordinate(out[dim]):
            coord = out[dim]
            attrs = {**coord.attrs, _LABELS_OF: dim}
            out = out.drop_vars(dim).assign_coords(
                {f"{dim}{_LABEL_SUFFIX}": (dim, coord.values, attrs)})
    return out


def decode(ds: xr.Dataset, index: bool = True) -> xr.Dataset:
    """Undo :func:`encode`: producer units, labelled dimensions, ``time`` as the dimension
    of its axis (with a pandas index on it if ``index``; building one reads the axis)."""
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
    if "time" in ds.coords and ds["time"].dims == (TIME_DIM,):
        ds = ds.swap_dims({TIME_DIM: "time"})
        if not index:
            ds = ds.drop_indexes("time")
    return ds
