"""The time base of a channel whose format does not carry one in the channel itself.

Shared by the readers: a ``time:`` channel named in the mapping, else the file's
``sample_rate:``, else an error that says which of the two to give.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from gbpipe.errors import DataError
from gbpipe.measured.channels import Channel
from gbpipe.measured.spec import FileSpec

__all__ = ["attach"]

_TIME_SCALE = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "min": 60.0, "h": 3600.0}


def attach(values: np.ndarray, unit: str | None, fspec: FileSpec, source: str, name: str,
           read_time: Callable[[str], np.ndarray]) -> Channel:
    """A :class:`Channel` of ``values`` with the time base the mapping gives for the file.

    Parameters
    ----------
    values : numpy.ndarray
        The channel's samples.
    unit : str or None
        The channel's unit as the file states it.
    fspec : FileSpec
        The file's mapping: ``time`` (a channel of times in ``time_unit``) or
        ``sample_rate`` [Hz].
    source, name : str
        File and channel, for the error message.
    read_time : callable
        Reads the time channel by name (the format's own reader).
    """
    if fspec.time is not None:
        if fspec.time_unit not in _TIME_SCALE:
            raise DataError(f"{source}: field 'time_unit'", f"unknown time unit "
                            f"{fspec.time_unit!r}; one of {', '.join(_TIME_SCALE)}")
        t = np.asarray(read_time(fspec.time), dtype=float) * _TIME_SCALE[fspec.time_unit]
        if t.size != values.size:
            raise DataError(f"{source}: channel '{name}'", f"has {values.size} samples but "
                            f"time channel '{fspec.time}' has {t.size}")
        return Channel(values, unit, time=t)
    if fspec.sample_rate is not None:
        return Channel(values, unit, t0=0.0, dt=1.0 / fspec.sample_rate)
    raise DataError(f"{source}: channel '{name}'", "the file carries no time base for this "
                    "channel: give the file a time: channel or a sample_rate: [Hz]")
