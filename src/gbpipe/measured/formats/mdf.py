"""ASAM MDF (3 and 4) through asammdf, an optional dependency (``pip install gbpipe[mdf]``).

Addressing: the channel name as asammdf lists it. Time base: the channel's own master
(time) channel, absolute start from the file header's ``start_time``. Unit: the
channel's unit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gbpipe.errors import DataError
from gbpipe.measured.channels import Channel, find
from gbpipe.measured.spec import FileSpec

__all__ = ["MdfSource", "MISSING"]

MISSING = "reading MDF files needs asammdf: pip install gbpipe[mdf]"


class MdfSource:
    """Channels of one MDF file (see the module docstring)."""

    def __init__(self, path: Path, fspec: FileSpec) -> None:
        self.path, self.fspec = path, fspec
        try:
            from asammdf import MDF  # optional dependency
        except ImportError as exc:
            raise DataError(str(path), MISSING) from exc
        try:
            self._mdf = MDF(str(path))
        except Exception as exc:  # asammdf raises several types on a bad file
            raise DataError(str(path), f"not a readable MDF file: {exc}") from exc
        masters = {"t", "time", "Time"}
        self._names = [n for n in self._mdf.channels_db if n not in masters]
        start = self._mdf.header.start_time
        self._epoch = np.datetime64(start.replace(tzinfo=None), "ns") if start else None

    def names(self) -> list[str]:
        return list(self._names)

    def prefetch(self, names: list[str]) -> None:
        """Nothing to do: asammdf reads channels on demand."""

    def close(self) -> None:
        self._mdf.close()

    def read(self, name: str) -> Channel:
        name = find(name, self._names, str(self.path))
        sig = self._mdf.get(name)
        values = np.asarray(sig.samples)
        if not np.issubdtype(values.dtype, np.number):
            raise DataError(f"{self.path}: channel '{name}'", "not numeric")
        return Channel(values, sig.unit or None, time=np.asarray(sig.timestamps, float),
                       epoch=self._epoch)
