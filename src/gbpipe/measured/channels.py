"""One channel as read from a file, and how a mapping's channel name finds it.

Every format reader returns a :class:`Channel`: the values, the unit the file states (if
any) and the time base — either uniform (``t0`` + ``dt``) or explicit sample ``time``
stamps. ``epoch`` is the absolute time of clock zero when the file knows it (TDMS
``wf_start_time``, MDF start time); without it, times are seconds on the file's own clock.
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gbpipe.errors import DataError

__all__ = ["Channel", "find", "missing_channel"]


@dataclass
class Channel:
    """Samples of one channel with their time base.

    Attributes
    ----------
    values : numpy.ndarray, shape (n,)
        Samples, float64, in the file's unit. A reader returns a fresh array on every
        call, so the caller may convert it in place.
    unit : str or None
        Unit stated by the file (``None`` when the file carries none).
    t0, dt : float or None
        Uniform time base: sample ``k`` is at ``t0 + k * dt`` [s]. ``None`` when ``time``
        is given instead.
    time : numpy.ndarray or None
        Explicit sample times [s] (a time channel), same length as ``values``.
    epoch : numpy.datetime64 or None
        Absolute time of clock zero, when the file knows it.
    """

    values: np.ndarray
    unit: str | None = None
    t0: float | None = None
    dt: float | None = None
    time: np.ndarray | None = None
    epoch: np.datetime64 | None = None

    def __post_init__(self) -> None:
        self.values = np.asarray(self.values, dtype=float).ravel()

    @property
    def rate(self) -> float | None:
        """Sample rate [Hz] of a uniform time base, else ``None``."""
        return None if self.dt is None else 1.0 / self.dt


def missing_channel(source: str, name: str, available: Sequence[str]) -> DataError:
    """The error for a channel that is not in ``source``: the closest names and the list."""
    close = difflib.get_close_matches(name, list(available), n=3, cutoff=0.5)
    hint = f" Did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
    listing = ", ".join(repr(a) for a in available[:40])
    more = f" (+{len(available) - 40} more)" if len(available) > 40 else ""
    return DataError(f"{source}: channel '{name}'",
                     f"no such channel.{hint} Channels in the file: {listing}{more}")


def find(name: str, available: Sequence[str], source: str) -> str:
    """Return ``name`` if ``available`` holds it, else raise with a suggestion.

    A match ignoring case and blanks is accepted when it is unique (``"Drive torque"``
    for ``"drive torque"``, ``"x[:,0]"`` for ``"x[:, 0]"``): loggers and spreadsheets
    change case and spacing freely.

    Raises
    ------
    gbpipe.errors.DataError
        Naming ``source``, the channel, the closest existing names and the full list.
    """
    if name in available:
        return name
    def fold(s: str) -> str:
        return "".join(s.split()).casefold()

    folded = [a for a in available if fold(a) == fold(name)]
    if len(folded) == 1:
        return folded[0]
    raise missing_channel(source, name, available)
