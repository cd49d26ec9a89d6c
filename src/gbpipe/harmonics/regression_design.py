"""The design of the harmonic regression (:mod:`gbpipe.harmonics.regression`), block by block.

The normal equations are accumulated over blocks of samples that each lie inside one knot
interval (:func:`block_cuts`), so each block touches only ``degree + 1`` amplitude
functions. Per block: the phases of every line (:func:`line_phases`), the local design
matrix of the amplitude functions times the slow mean and each line's cosine and sine
(:func:`local_design`), and the border columns of the modal carriers
(:func:`carrier_blocks`, :func:`border_design`).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np

from gbpipe.harmonics.amplitude_basis import AmplitudeBasis
from gbpipe.harmonics.crossings import modal_carriers

__all__ = ["block_cuts", "border_design", "carrier_blocks", "line_phases", "local_design"]


def block_cuts(times: np.ndarray, breaks: np.ndarray, block: int) -> np.ndarray:
    """Sample cuts of the blocks: every ``block`` samples and at every knot, so that no
    block straddles a knot.

    Parameters
    ----------
    times : ndarray, shape (n,)
        Sample times [s].
    breaks : ndarray
        Knot times of the amplitude basis [s].
    block : int
        Most samples per block.

    Returns
    -------
    ndarray of int
        Increasing cuts from 0 to ``n``: block ``k`` is ``cuts[k]:cuts[k + 1]``.
    """
    cuts = np.union1d(np.arange(0, times.size, block), np.searchsorted(times, breaks))
    return np.append(cuts, times.size)


def line_phases(angles: Sequence[np.ndarray], lines: Sequence[tuple[int, np.ndarray]],
                a: int, b: int) -> np.ndarray:
    """Phases of every line on samples ``a:b``, each group of orders on its shaft's angle.

    Parameters
    ----------
    angles : sequence of ndarray
        Shaft angles [rad] at every sample (the tachometer's, then a second shaft's).
    lines : sequence of (int, ndarray)
        Per group: the index of its angle in ``angles`` and its orders [-].
    a, b : int
        First and one-past-last sample of the block.

    Returns
    -------
    ndarray, shape (b - a, lines)
        Phases [rad].
    """
    return np.concatenate([np.outer(angles[k][a:b], ords) for k, ords in lines], axis=1)


def local_design(basis: AmplitudeBasis, t: np.ndarray, phases: np.ndarray
                 ) -> tuple[np.ndarray, int]:
    """Design matrix of one block and its first column among all the unknowns.

    Parameters
    ----------
    basis : AmplitudeBasis
        The amplitudes' basis in time.
    t : ndarray, shape (n,)
        The block's sample times [s] (inside one knot interval).
    phases : ndarray, shape (n, lines)
        :func:`line_phases` of the block [rad].

    Returns
    -------
    design : ndarray, shape (n, support * (2 lines + 1))
        Per amplitude function the block touches: the slow mean, then the cosine and sine
        of each line, times the function.
    first : int
        Column of ``design[:, 0]`` among all the unknowns.
    """
    vals, first = basis.values(t)
    trig = np.empty((t.size, 2 * phases.shape[1] + 1))
    trig[:, 0] = 1.0
    trig[:, 1::2] = np.cos(phases)
    trig[:, 2::2] = np.sin(phases)
    design = (vals[:, :, None] * trig[:, None, :]).reshape(t.size, -1)
    return design, first * trig.shape[1]


def carrier_blocks(angles: Sequence[np.ndarray], fs: float, modes: np.ndarray,
                   carriers_of: Sequence[tuple[int, np.ndarray, Sequence[tuple[int, int]]]],
                   cuts: np.ndarray) -> Iterator[np.ndarray]:
    """The modal carriers of every angle's (order, mode) pairs, block by block.

    Parameters
    ----------
    angles : sequence of ndarray
        As :func:`line_phases`.
    fs : float
        Sample rate [Hz].
    modes : ndarray, shape (modes, 2)
        Frequency [Hz] and damping ratio [-] of each mode.
    carriers_of : sequence of (int, ndarray, sequence of (int, int))
        Per angle: its index in ``angles``, its orders, and the (order, mode) index pairs
        that get a carrier (:func:`gbpipe.harmonics.crossings.crossing_pairs`).
    cuts : ndarray of int
        :func:`block_cuts`.

    Yields
    ------
    ndarray, complex, shape (block samples, pairs)
        Every angle's carriers side by side (each on the angle of the shaft its order is
        locked to); a real ``(0, 0)`` array for every block where no angle has a pair.
    """
    gens = [modal_carriers(angles[k], fs, ords, modes, pairs, cuts)
            for k, ords, pairs in carriers_of if pairs]
    for _ in range(len(cuts) - 1):
        yield np.concatenate([next(g) for g in gens], axis=1) if gens else np.empty((0, 0))


def border_design(carriers: np.ndarray) -> np.ndarray:
    """Border columns of one block: the real and imaginary part of each modal carrier.

    Parameters
    ----------
    carriers : ndarray, complex, shape (n, pairs)
        A block of :func:`carrier_blocks`.

    Returns
    -------
    ndarray, shape (n, 2 pairs)
        Per carrier, its real part, then its imaginary part.
    """
    return np.stack([carriers.real, carriers.imag], axis=2).reshape(carriers.shape[0], -1)
