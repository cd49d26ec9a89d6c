"""The angle of a second line-carrying shaft, from the record's speeds.

The tachometer gives the angle of one shaft (the GB1 HSS on the paper's bench); the lines
of the other gearbox (its shaft orders and mesh errors) and of the motor on its side are
locked to *that* shaft's angle, which differs from the tachometer's by the twist of the
chain between them. The twist is not constant: when the speed loop accelerates the
chain it moves by tens of mrad within a fraction of a second (42 mrad at 18 rpm/s on the
paper's bench, docs/removal.md), and a line of order ``o`` locked to the other shaft
changes phase against the tachometer angle by ``o x twist``: 2.4 rad for the mesh-3
order 58, faster than a slow amplitude envelope can follow.

Where the record has no second tachometer, the twist is the time integral of the two
shafts' measured speeds' difference (:func:`shaft_twist`), the other shaft's speed
brought to the tachometer shaft by the kinematic ratio. Why the difference and not the
other speed integrated alone: a common gain error of the speed channels then scales only
the twist (mrad), not the whole angle (thousands of rad), and the tachometer keeps the
angle's long-term accuracy. The speed noise integrates to a random walk: on the
benchmark's sweeps (2e-3 rad/s rms white speed noise at 10 kHz, encoder quantisation) the
twist from the measured speeds lies 0.17-0.39 mrad rms from the true one (0.02 rad of
phase at order 58), against 14-44 mrad of the twist's own change.

The second angle of a record is ``theta + twist`` (``theta`` the tachometer angle).
Which orders get a second line (:func:`second_lines`): an order of a family locked to
the second shaft whose phase the twist moves by more than ``twist_phase`` beyond what the
method's own envelope follows (``order x max|twist - envelope fit of twist|``).
Elsewhere the envelope on the tachometer angle takes the line to better than
``twist_phase`` of its amplitude, and a second envelope would only take more of the
broadband response (it doubles the parameters near the order). Only the regression takes a ``twist``
(:func:`gbpipe.harmonics.residual_regression`): it fits both lines of an order jointly.
The Vold-Kalman filter (:mod:`gbpipe.harmonics.vkf`) solves its orders one after the
other (backfitting), and two envelopes of one order on angles that differ by a slowly
varying twist trade their shared part over many passes: on the test record of
``tests/harmonics/test_shaft_angles.py`` a line of the second shaft alone was left at
31.6 dB without its angle, 35.6 dB with it after the default passes, 48 dB after 200.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping

import numpy as np
from scipy.integrate import cumulative_trapezoid

from gbpipe.errors import DataError
from gbpipe.harmonics.checks import as_positive, as_signal

__all__ = ["shaft_twist", "checked_twist", "second_lines"]


def shaft_twist(speed_tacho: np.ndarray, speed_other: np.ndarray, fs: float,
                ratio: float = 1.0) -> np.ndarray:
    """Angle of a second shaft minus the tachometer shaft's, from their speeds [rad].

    Parameters
    ----------
    speed_tacho : array_like, shape (n,)
        Speed of the tachometer's shaft at every sample [rad/s] (measured).
    speed_other : array_like, shape (n,)
        Speed of the second shaft at the same samples [rad/s] (measured).
    fs : float
        Sample rate [Hz].
    ratio : float
        Kinematic ratio ``speed_other / speed_tacho`` of a rigid chain [-] (1 for the two
        HSS of a back-to-back bench of twin gearboxes).

    Returns
    -------
    numpy.ndarray
        ``integral (speed_other / ratio - speed_tacho) dt`` from 0 at the first sample
        (trapezoidal) [rad, in the tachometer shaft's radians]: add it to the tachometer
        angle for the second shaft's angle (its constant offset is a line phase, which
        every fit takes).

    Raises
    ------
    DataError
        A speed with NaN/inf samples, or speeds of different lengths.
    ValueError
        A sample rate or ratio that is not positive.
    """
    a = as_signal(speed_tacho, "speed_tacho")
    b = as_signal(speed_other, "speed_other")
    if a.size != b.size:
        raise DataError("speed_other", f"has {b.size} samples, speed_tacho {a.size}: pass "
                        "both speeds of the same record")
    fs = as_positive(fs, "fs", "Hz")
    ratio = as_positive(ratio, "ratio", "-")
    return cumulative_trapezoid(b / ratio - a, dx=1.0 / fs, initial=0.0)


def checked_twist(twist: object, n: int) -> np.ndarray:
    """``twist`` as finite float samples, one per sample of an ``n``-sample record [rad].

    Raises
    ------
    DataError
        NaN/inf samples, or a length other than ``n`` (naming the fix).
    """
    tw = as_signal(twist, "twist")
    if tw.size != n:
        raise DataError("twist", f"has {tw.size} samples, the record {n}: give the second "
                        "shaft's angle minus the tachometer's at every sample of the record "
                        "(gbpipe.harmonics.shaft_twist of its two speeds)")
    return tw


def second_lines(families: Mapping[str, np.ndarray], twist_families: Collection[str] | None,
                 unfollowed: float, twist_phase: float) -> np.ndarray:
    """Which orders also get a line on the second shaft's angle (module notes).

    Parameters
    ----------
    families : mapping str -> numpy.ndarray
        The orders of each family [HSS orders], in the order the method stacks them.
    twist_families : collection of str or None
        The families locked to the second shaft too (None: all).
    unfollowed : float
        The largest change of the twist that the method's envelope does not follow [rad].
    twist_phase : float
        Phase change [rad] above which an order gets its second line.

    Returns
    -------
    numpy.ndarray of bool
        One entry per order, the families' orders concatenated.

    Raises
    ------
    ValueError
        ``twist_phase`` not positive.
    """
    twist_phase = as_positive(twist_phase, "twist_phase", "rad")
    locked = np.concatenate([np.full(np.size(o), twist_families is None
                                     or name in twist_families)
                             for name, o in families.items()])
    orders = np.concatenate([np.asarray(o, dtype=float) for o in families.values()])
    return locked & (orders * unfollowed > twist_phase)
