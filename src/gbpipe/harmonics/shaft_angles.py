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
angle's long-term accuracy. The speed noise integrates to a random walk: 2e-3 rad/s rms
white at 10 kHz gives 2.3e-4 rad rms after 133 s (0.013 rad of phase at order 58).

The second angle of a record is ``theta + twist`` (``theta`` the tachometer angle):
:func:`gbpipe.harmonics.residual_regression` fits the orders of its ``twist_families``
on both.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import cumulative_trapezoid

from gbpipe.errors import DataError
from gbpipe.harmonics.checks import as_positive, as_signal

__all__ = ["shaft_twist", "checked_twist"]


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
