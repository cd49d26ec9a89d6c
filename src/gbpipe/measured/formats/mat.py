"""MATLAB files: v5 through :func:`scipy.io.loadmat`, v7.3 (HDF5) through h5py.

Addressing
    ``name`` for a 1-D variable (or a single column), ``name[:, k]`` for column ``k``
    (0-based) of a 2-D variable, samples along the rows.
Time base
    The mapping's ``time:`` (a variable, same addressing) or ``sample_rate:``.
Simcenter Testlab (LMS Test.Lab) export
    One struct per signal (often ``Signal``, ``Signal_0``…) with fields
    ``x_values`` (``start_value``, ``increment``, ``number_of_values``) and ``y_values``
    (``values``, shape (n,) or (n, channels); ``quantity.label`` the unit;
    ``quantity.unit_transformation.factor``/``offset`` the conversion from the stored
    values to that unit), and ``function_record`` (``name``: the channel names). Such a
    struct is addressed like a variable (``Signal`` or ``Signal[:, k]``), its channels
    also by ``Signal/<function_record name>``; its time base comes from ``x_values``.

A v7.3 file is HDF5 storing MATLAB's column-major arrays, so a MATLAB (n, k) matrix is
an HDF5 (k, n) dataset: it is transposed on reading.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import scipy.io

from gbpipe.errors import DataError
from gbpipe.measured.channels import Channel, missing_channel
from gbpipe.measured.formats.timebase_of import attach
from gbpipe.measured.spec import FileSpec

__all__ = ["MatSource"]

_COLUMN = re.compile(r"^(?P<var>.+)\[\s*:\s*,\s*(?P<k>\d+)\s*\]$")


def _h5(obj: Any) -> Any:
    """An h5py object as numpy arrays / dicts, arrays back in MATLAB's (row, col) order."""
    if isinstance(obj, h5py.Group):
        return {k: _h5(v) for k, v in obj.items() if not k.startswith("#")}
    data = obj[()]
    cls = obj.attrs.get("MATLAB_class", b"")
    cls = cls.decode() if isinstance(cls, bytes) else str(cls)
    if cls == "char":
        return "".join(chr(c) for c in np.asarray(data).ravel())
    return np.asarray(data).T


def _is_testlab(value: Any) -> bool:
    return isinstance(value, dict) and "x_values" in value and "y_values" in value


def _columns(shape: tuple[int, ...]) -> int | None:
    """Number of addressable columns of a numeric array (1 for a vector), ``None`` if not
    a 1-D or 2-D array of samples."""
    if len(shape) == 1 or (len(shape) == 2 and 1 in shape):
        return 1
    if len(shape) == 2:
        return shape[1]
    return None


def _testlab_names(value: dict) -> list[str]:
    rec = value.get("function_record", {})
    names = rec.get("name", []) if isinstance(rec, dict) else []
    if isinstance(names, str):
        names = [names]
    return [str(n) for n in np.ravel(np.asarray(names, dtype=object))]


class MatSource:
    """Variables of one MAT file (see the module docstring)."""

    def __init__(self, path: Path, fspec: FileSpec) -> None:
        self.path, self.fspec = path, fspec
        self._h5file = None
        try:
            if h5py.is_hdf5(path):
                self._h5file = h5py.File(path, "r")
                self._vars = {k: v for k, v in self._h5file.items() if not k.startswith("#")}
            else:
                raw = scipy.io.loadmat(path, simplify_cells=True)
                self._vars = {k: v for k, v in raw.items() if not k.startswith("__")}
        except Exception as exc:  # scipy/h5py raise several types on a bad file
            raise DataError(str(path), f"not a readable MAT file: {exc}") from exc
        self._names: dict[str, tuple[str, int | str | None]] = {}
        for var, value in self._vars.items():
            self._add(var, value)

    def _value(self, var: str) -> Any:
        value = self._vars[var]
        return _h5(value) if self._h5file is not None else value

    def _add(self, var: str, value: Any) -> None:
        if isinstance(value, h5py.Group):
            if "x_values" in value and "y_values" in value:
                value = _h5(value)
            else:
                return
        if _is_testlab(value):
            y = np.asarray(value["y_values"]["values"])
            ncol = _columns(y.shape) or 0
            if ncol == 1:
                self._names[var] = (var, None)
            for k in range(ncol if ncol > 1 else 0):
                self._names[f"{var}[:, {k}]"] = (var, k)
            for k, label in enumerate(_testlab_names(value)[:max(ncol, 1)]):
                self._names[f"{var}/{label}"] = (var, k if ncol > 1 else None)
            return
        shape = value.shape if hasattr(value, "shape") else np.shape(value)
        dtype = getattr(value, "dtype", np.asarray(value).dtype)
        if not np.issubdtype(dtype, np.number):
            return
        if self._h5file is not None:
            shape = tuple(reversed(shape))
        ncol = _columns(tuple(shape))
        if ncol == 1:
            self._names[var] = (var, None)
        elif ncol:
            for k in range(ncol):
                self._names[f"{var}[:, {k}]"] = (var, k)

    def names(self) -> list[str]:
        return list(self._names)

    def prefetch(self, names: list[str]) -> None:
        """Nothing to do: variables are read on their own."""

    def close(self) -> None:
        if self._h5file is not None:
            self._h5file.close()

    def _resolve(self, name: str) -> tuple[str, int | None]:
        key = name
        m = _COLUMN.match(name)
        if m:
            key = f"{m['var'].strip()}[:, {int(m['k'])}]"
        if key not in self._names:
            raise missing_channel(str(self.path), name, self.names())
        return self._names[key]

    def _array(self, name: str) -> tuple[np.ndarray, Any]:
        var, k = self._resolve(name)
        value = self._value(var)
        data = value["y_values"]["values"] if _is_testlab(value) else value
        arr = np.asarray(data)
        if not np.isrealobj(arr):
            raise DataError(f"{self.path}: channel '{name}'", "complex values: not a signal")
        arr = arr.reshape(arr.shape[0], -1) if arr.ndim == 2 and 1 not in arr.shape else arr
        col = arr.ravel() if k is None else arr[:, k]
        return np.array(col, dtype=float), value  # a fresh array: the caller owns it

    def read(self, name: str) -> Channel:
        values, value = self._array(name)
        if not _is_testlab(value):
            return attach(values, None, self.fspec, str(self.path), name,
                          lambda t: self._array(t)[0])
        x, q = value["x_values"], value["y_values"].get("quantity", {})
        unit = q.get("label") if isinstance(q, dict) else None
        tf = q.get("unit_transformation", {}) if isinstance(q, dict) else {}
        if isinstance(tf, dict) and tf:
            # Testlab stores values in its internal unit; factor/offset give the label's unit.
            values = values * float(tf.get("factor", 1.0)) + float(tf.get("offset", 0.0))
        try:
            t0, dt = float(x["start_value"]), float(x["increment"])
        except (KeyError, TypeError) as exc:
            raise DataError(f"{self.path}: channel '{name}'", "Testlab struct without "
                            "x_values.start_value / x_values.increment") from exc
        if not dt > 0:
            raise DataError(f"{self.path}: channel '{name}'",
                            f"field 'x_values.increment' = {dt} is not positive")
        return Channel(values, str(unit) if unit else None, t0=t0, dt=dt)
