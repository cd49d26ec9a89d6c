"""Universal file format data set 58 (function at nodal DOF: time series) through pyuff.

Addressing: the set's ID line 1 (``id1``), or its number ``#n`` (1-based, in file
order, counting data sets 58 only). Two sets with the same ID line are addressed by
number. Time base: ``abscissa_min`` + k ``abscissa_inc`` for evenly spaced sets
(abscissa spacing 1), the stored abscissa otherwise. Unit: the ordinate units label.
Both ASCII and binary (58b) sets are read. Only time-domain sets (function type 1,
general or time response) are accepted.

Precision: the UFF header stores ``abscissa_min`` and ``abscissa_inc`` in ``E13.5``
format, i.e. 6 significant digits: a rate of 2048 Hz comes back as 1/4.88281e-4 s
(0.6 ppm off), a drift of 0.06 samples over 10^5 samples.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyuff

from gbpipe.errors import DataError
from gbpipe.measured.channels import Channel, missing_channel
from gbpipe.measured.spec import FileSpec

__all__ = ["UffSource"]

_TIME_FUNCTION_TYPES = (0, 1)  # 0: general or unknown, 1: time response


class UffSource:
    """Data sets 58 of one universal file (see the module docstring)."""

    def __init__(self, path: Path, fspec: FileSpec) -> None:
        self.path, self.fspec = path, fspec
        try:
            uff = pyuff.UFF(str(path))
            types = np.asarray(uff.get_set_types())
            self._index = [int(i) for i in np.flatnonzero(types == 58)]
            self._uff = uff
        except Exception as exc:  # pyuff raises bare Exception on unreadable files
            raise DataError(str(path), f"not a readable universal file: {exc}") from exc
        if not self._index:
            raise DataError(str(path), f"no data set 58 (time series) in the file; set "
                            f"types found: {sorted(set(types.tolist()))}")
        heads = [self._uff.read_sets(i, header_only=True) for i in self._index]
        self._ids = [str(h.get("id1", "")).strip() for h in heads]

    def names(self) -> list[str]:
        unique = [i for i in self._ids if self._ids.count(i) == 1]
        return unique + [f"#{n + 1}" for n in range(len(self._ids))]

    def prefetch(self, names: list[str]) -> None:
        """Nothing to do: each set is read on its own."""

    def close(self) -> None:
        """pyuff keeps no file open."""

    def _position(self, name: str) -> int:
        if name.startswith("#") and name[1:].isdigit():
            n = int(name[1:])
            if 1 <= n <= len(self._index):
                return n - 1
        elif self._ids.count(name) == 1:
            return self._ids.index(name)
        raise missing_channel(str(self.path), name, self.names())

    def read(self, name: str) -> Channel:
        pos = self._position(name)
        try:
            s = self._uff.read_sets(self._index[pos])
        except Exception as exc:
            raise DataError(f"{self.path}: channel '{name}'",
                            f"cannot read data set 58 #{pos + 1}: {exc}") from exc
        if int(s.get("func_type", 0)) not in _TIME_FUNCTION_TYPES:
            raise DataError(f"{self.path}: channel '{name}'", f"field 'func_type' = "
                            f"{s['func_type']}: not a time series (1 = time response)")
        if np.iscomplexobj(s["data"]):
            raise DataError(f"{self.path}: channel '{name}'", "complex ordinate: a spectrum "
                            "or FRF, not a time series")
        unit = str(s.get("ordinate_axis_units_lab", "")).strip()
        unit = None if unit in ("", "NONE") else unit
        values = np.asarray(s["data"], dtype=float)
        if int(s.get("abscissa_spacing", 0)) == 1:
            dt = float(s["abscissa_inc"])
            if not dt > 0:
                raise DataError(f"{self.path}: channel '{name}'",
                                f"field 'abscissa_inc' = {dt} is not positive")
            return Channel(values, unit, t0=float(s["abscissa_min"]), dt=dt)
        return Channel(values, unit, time=np.asarray(s["x"], dtype=float))
