"""A harmonic removal of an hour-long record in overlapping pieces (bounded memory).

The joint TSA of one channel holds about 14 arrays of the channel's length at its peak
(the angle map, each family's grid and back-map positions, the families' estimates, the
spline coefficients; :class:`gbpipe.harmonics.averaging.CyclePlan`): 1.9 GB for one
channel of an hour at 5 kHz (18 M samples). Its averages are local: a block of
``n_cycles`` cycles of each family, so a piece of the record with whole blocks around
every sample it keeps gives that sample an estimate of the same kind as the whole record
does (from the blocks of the piece, whose boundaries fall elsewhere than the whole
record's: the estimates differ by the noise of a block mean, not in their quality).

:func:`by_pieces` runs a removal on pieces of :data:`PIECE` samples, each widened on
both sides by a margin of ``margin`` samples (at least one block of the longest cycle and
one revolution), and keeps each piece's centre. A record up to ``PIECE + 2 margin``
samples is removed in one call, exactly as before (every record of the default and CI
runs: the longest, the 72-s sweep at 5 kHz, has 360 000 samples).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from gbpipe.progress import Progress

__all__ = ["PIECE", "by_pieces", "block_margin", "slowest_revolution"]

log = logging.getLogger(__name__)

#: Samples kept from one piece (14 min at 5 kHz): the joint TSA of a piece and its
#: margins holds about 0.5 GB.
PIECE = 1 << 22


def slowest_revolution(pulse_times: np.ndarray, pulses_per_rev: int) -> float:
    """Longest revolution of the tacho shaft in ``pulse_times`` [s] (0 without two pulses):
    the widest pulse spacing times the pulses per revolution.

    Parameters
    ----------
    pulse_times : ndarray
        Tacho pulse times [s].
    pulses_per_rev : int
        Pulses per revolution of the tacho shaft.
    """
    spacing = np.diff(np.asarray(pulse_times, dtype=float))
    return float(spacing.max()) * pulses_per_rev if spacing.size else 0.0


def block_margin(pulse_times: np.ndarray, pulses_per_rev: int, fs: float,
                 cycle_orders: list[float], n_cycles: int) -> int:
    """Samples of one averaging block of the longest cycle at the slowest revolution in
    ``pulse_times``, plus one revolution: the margin :func:`by_pieces` needs.

    Parameters
    ----------
    pulse_times : ndarray
        Tacho pulse times [s].
    pulses_per_rev : int
        Pulses per revolution of the tacho shaft.
    fs : float
        Sample rate [Hz].
    cycle_orders : list of float
        Cycle frequency of each family [orders of the tacho shaft].
    n_cycles : int
        Cycles per averaging block.
    """
    rev = slowest_revolution(pulse_times, pulses_per_rev)                   # s
    longest = rev / min(float(c) for c in cycle_orders)                      # s per cycle
    return int(np.ceil((n_cycles * longest + rev) * fs))


def by_pieces(x: np.ndarray, fs: float, pulse_times: np.ndarray, margin: int,
              remove: Callable[[np.ndarray, np.ndarray, float], np.ndarray],
              piece: int = PIECE, t0: float = 0.0, out: np.ndarray | None = None,
              ) -> np.ndarray:
    """``remove`` of ``x`` in overlapping pieces.

    Parameters
    ----------
    x : ndarray, shape (n, ...)
        Record, sample ``i`` (along the first axis) at ``t0 + i / fs`` [s] (any unit).
    fs : float
        Sample rate [Hz].
    pulse_times : ndarray
        Tacho pulse times [s] on the record's time axis.
    margin : int
        Samples added on each side of a piece (:func:`block_margin`).
    remove : callable
        ``remove(x_piece, pulses_in_piece, t0)``: the residual of a piece whose first
        sample is at ``t0`` [s], of its shape, in a new array (``x_piece`` is a view of
        ``x``, whose margins the neighbouring pieces read too: never written).
    piece : int
        Samples kept from each piece (at least four margins).
    t0 : float
        Time of the first sample [s].
    out : ndarray, optional
        Array of ``x``'s shape the residual is written to; it may be ``x`` itself (the
        residual then replaces the record, which is held once: a piece's last ``margin``
        kept samples, the next piece's left margin, are written after that piece has
        read them). Default: a new array.

    Returns
    -------
    ndarray, shape of ``x``
        The residual, in the unit of ``x`` (``out`` when given).
    """
    piece = max(int(piece), 4 * margin)
    n = x.shape[0]
    if out is not None and out.shape != x.shape:
        raise ValueError(f"out has shape {out.shape}; the record, {x.shape}")
    if n <= piece + 2 * margin:
        if out is None:
            return remove(x, pulse_times, t0)
        out[...] = remove(x, pulse_times, t0)
        return out
    out = np.empty_like(x) if out is None else out
    starts = range(0, n, piece)
    progress = Progress(log, f"removal in {len(starts)} pieces of {piece} samples",
                        len(starts))
    held = slice(0, 0), x[:0].copy()  # samples written once the next piece has read them
    for k, a in enumerate(starts, 1):
        b = min(a + piece, n)
        lo, hi = max(a - margin, 0), min(b + margin, n)
        start, end = t0 + lo / fs, t0 + (hi - 1) / fs
        inside = (pulse_times >= start) & (pulse_times <= end)
        kept = remove(x[lo:hi], pulse_times[inside], start)[a - lo:b - lo]
        out[held[0]] = held[1]
        cut = b - a - (margin if b < n else 0)  # (a piece holds at least four margins)
        out[a:a + cut] = kept[:cut]
        held = slice(a + cut, b), kept[cut:].copy()
        del kept  # the piece's whole result, before the next piece's work
        progress(k)
    return out
