"""Order/mode crossings: where a removed order passes through a structural resonance,
and the swept modal response a line takes on there.

Where an order's frequency ``f_o(t) = o * rpm(t) / 60`` passes a mode ``(f_n, zeta)``,
the line in a response signal is the excitation times the bench's FRF at ``f_o(t)``: its
amplitude and phase ring up and down with the mode, on the mode's time constant
``1 / (zeta * 2 pi f_n)`` (0.15 s for the 62 Hz bench mode) and over the dwell in the
half-power band, faster than an envelope coarse enough to leave the broadband response
alone can follow. The modal part of that FRF is a complex first-order system
with the mode's pole ``p = -zeta w_n + i w_n sqrt(1 - zeta^2)``; filtering the order's
unit phasor ``exp(i o theta(t))`` through it gives the line's swept modal response
*exactly*, sweep-rate effects (the ringing after the passage) included: the *modal
carrier* :func:`modal_carriers`. A regression that spends one complex coefficient on
it per order and mode (:func:`gbpipe.harmonics.residual_regression`, ``modes``)
follows the ring-up with the few parameters of a slow envelope, instead of fine knots
that also take the broadband response of the mode around the order.

* :func:`half_power_band` -- the mode's half-power band ``f_n (1 +- zeta)`` [Hz];
* :func:`crossing_pairs` -- which orders come near which modes over a record;
* :func:`modal_carriers` -- the swept modal response of those orders;
* :func:`crossing_marks` -- per rpm bin, the (order, mode) pairs inside a half-power band;
* :func:`crossing_lines` -- per family, band and rpm bin, the order and mode of a crossing.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence

import numpy as np
from scipy.signal import lfilter

from gbpipe.harmonics.checks import as_positive

__all__ = ["half_power_band", "crossing_pairs", "modal_carriers", "crossing_marks",
           "crossing_lines", "as_modes"]


def as_modes(modes: Sequence[Sequence[float]] | np.ndarray) -> np.ndarray:
    """Modes as an array (modes, 2) of frequency [Hz] and damping ratio [-].

    Raises
    ------
    ValueError
        Not pairs, a frequency that is not positive, or a damping ratio outside (0, 1).
    """
    m = np.asarray(modes, dtype=float).reshape(-1, 2) if len(modes) else np.empty((0, 2))
    if np.any(~np.isfinite(m)) or np.any(m[:, 0] <= 0) or np.any(
            (m[:, 1] <= 0) | (m[:, 1] >= 1)):
        raise ValueError(f"modes must be pairs (frequency > 0 Hz, 0 < damping ratio < 1); "
                         f"got {m.tolist()}")
    return m


def half_power_band(modes: Sequence[Sequence[float]] | np.ndarray) -> np.ndarray:
    """Half-power band ``[f_n (1 - zeta), f_n (1 + zeta)]`` of each mode [Hz], (modes, 2).

    The band where a lightly damped mode's response power is above half its peak: the
    frequencies over which the line of a crossing order rings with the mode.
    """
    m = as_modes(modes)
    return np.column_stack([m[:, 0] * (1 - m[:, 1]), m[:, 0] * (1 + m[:, 1])])


def crossing_pairs(orders: np.ndarray, f_shaft: tuple[float, float],
                   modes: Sequence[Sequence[float]] | np.ndarray,
                   reach: float) -> list[tuple[int, int]]:
    """The (order index, mode index) pairs whose order frequency comes within ``reach``
    half-power half widths of the mode over the record.

    Parameters
    ----------
    orders : numpy.ndarray
        Orders [HSS orders].
    f_shaft : tuple of float
        Lowest and highest shaft rate of the record [rev/s].
    modes : array_like, shape (modes, 2)
        Frequency [Hz] and damping ratio [-] of each mode.
    reach : float
        Distance, in half-power half widths ``zeta f_n``, within which a pair counts [-].
    """
    m = as_modes(modes)
    reach = as_positive(reach, "reach", "half-power half widths")
    lo, hi = sorted(f_shaft)
    pairs = []
    for k, o in enumerate(np.asarray(orders, dtype=float)):
        for j, (fn, z) in enumerate(m):
            if o * hi >= fn * (1 - reach * z) and o * lo <= fn * (1 + reach * z):
                pairs.append((k, j))
    return pairs


def modal_carriers(theta: np.ndarray, fs: float, orders: np.ndarray,
                   modes: np.ndarray, pairs: Sequence[tuple[int, int]],
                   cuts: np.ndarray) -> Iterator[np.ndarray]:
    """Swept response of each pair's mode to its order's unit phasor, block by block.

    ``z' = p z + zeta w_n exp(i o theta)`` with ``p`` the mode's pole (the gain makes the
    resonant peak 1 in a steady state), discretised exactly for a sample-and-hold input,
    started in the steady state of the first sample's frequency (a record starts long
    after the bench did). Over the whole record, not only near the mode: the modal term
    of the FRF is the same function everywhere, so one coefficient (the residue times
    the excitation) describes it, while a carrier cut off away from the mode would leave
    a tail that a slow envelope cannot take. Block by block (the filter state carried
    over), so that memory stays one block, not the record times the pairs.

    Parameters
    ----------
    theta : numpy.ndarray
        Shaft angle of each sample [rad], at ``fs``.
    fs : float
        Sample rate [Hz].
    orders, modes, pairs
        As :func:`crossing_pairs` (``modes`` checked).
    cuts : numpy.ndarray
        Block boundaries, increasing sample indices from 0 to ``len(theta)``.

    Yields
    ------
    numpy.ndarray, complex, shape (block, pairs)
        The carriers [-] of each block in turn: ``exp(i o theta) H(f_o)`` with ``H`` of
        peak 1 while the sweep is slow against the mode's decay, the exact swept
        response otherwise.
    """
    dt = 1.0 / fs
    k = np.array([kk for kk, _ in pairs], dtype=int)
    fn, z = (np.array([modes[j][i] for _, j in pairs], dtype=float) for i in (0, 1))
    wn = 2 * np.pi * fn
    p = -z * wn + 1j * wn * np.sqrt(1 - z * z)
    pole = np.exp(p * dt)
    gain = z * wn * (pole - 1) / p  # held input -> exact state step, peak gain 1
    o = orders[k]
    rate0 = (theta[1] - theta[0]) / dt if theta.size > 1 else 0.0  # [rad/s]
    state = z * wn * np.exp(1j * o * theta[0]) / (1j * o * rate0 - p)  # steady state
    # an order near several modes drives each of them with one phasor: computed once
    distinct, column = np.unique(o, return_inverse=True)
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        u = np.exp(1j * np.outer(theta[a:b], distinct))
        y = np.empty((b - a, len(pairs)), dtype=complex)
        for c in range(len(pairs)):  # a few pairs: the recursion is compiled per pair
            # direct form II transposed: y[0] = zi, then y[n] = pole y[n-1] + gain u[n-1]
            y[:, c], zf = lfilter([0.0, gain[c]], [1.0, -pole[c]], u[:, column[c]],
                                  zi=[state[c]])
            state[c] = zf[0]
        yield y


def crossing_marks(orders: np.ndarray, rpm_lower: np.ndarray, rpm_upper: np.ndarray,
                   modes: Sequence[Sequence[float]] | np.ndarray) -> np.ndarray:
    """Which orders lie inside which mode's half-power band in each rpm bin.

    Returns
    -------
    numpy.ndarray of bool, shape (bins, orders, modes)
        True where the order's frequency range over the bin, ``o [rpm_lower,
        rpm_upper] / 60`` Hz, overlaps the mode's :func:`half_power_band`.
    """
    band = half_power_band(modes)
    o = np.asarray(orders, dtype=float)[None, :, None]
    f_lo = np.asarray(rpm_lower, dtype=float)[:, None, None] / 60.0 * o
    f_hi = np.asarray(rpm_upper, dtype=float)[:, None, None] / 60.0 * o
    return (f_hi >= band[None, None, :, 0]) & (f_lo <= band[None, None, :, 1])


def crossing_lines(families: Mapping[str, np.ndarray], rpm_lower: np.ndarray,
                   rpm_upper: np.ndarray, modes: Sequence[Sequence[float]] | np.ndarray,
                   band_limits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per family, frequency band and rpm bin: the order inside a mode's half-power band,
    and that mode.

    Parameters
    ----------
    families : mapping str -> array_like
        Orders [HSS orders] of each family.
    rpm_lower, rpm_upper : array_like
        Speed limits of each rpm bin [rev/min].
    modes : array_like, shape (modes, 2)
        Frequency [Hz] and damping ratio [-] of each mode.
    band_limits : numpy.ndarray, shape (bands, 2)
        Lower and upper limit of each frequency band [Hz]; a mode belongs to the bands
        holding its frequency.

    Returns
    -------
    order, mode : numpy.ndarray, shape (families, bands, bins)
        The lowest order of the family within the half-power band of a mode of the band
        [HSS orders], and that mode's frequency [Hz]; NaN where none is.
    """
    m = as_modes(modes)
    shape = (len(families), len(band_limits), np.size(rpm_lower))
    order, mode = np.full(shape, np.nan), np.full(shape, np.nan)
    for k, ords in enumerate(families.values()):
        o = np.sort(np.asarray(ords, dtype=float))
        marks = crossing_marks(o, rpm_lower, rpm_upper, m)  # (bins, orders, modes)
        for b, (lo, hi) in enumerate(band_limits):
            of_band = (m[:, 0] >= lo) & (m[:, 0] <= hi)
            for i in range(shape[2]):
                hit = np.argwhere(marks[i][:, of_band])  # (order, mode) rows, by order
                if hit.size:
                    order[k, b, i] = o[hit[0, 0]]
                    mode[k, b, i] = m[of_band][hit[0, 1], 0]
    return order, mode
