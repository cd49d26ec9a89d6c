"""N4SID (Van Overschee & De Moor, Automatica 30, 1994), unweighted, with shift invariance.

The SVD is taken of the oblique projection ``O = Y_f /_{U_f} Z_p`` (future outputs along the
future inputs onto the past data). ``A`` and ``C`` then come from the shift invariance of the
extended observability matrix and ``B, D`` from a linear regression that needs no state
sequence (the "robust" variant), unlike the simple state-sequence N4SID whose finite-horizon
bias does not vanish with more data.
"""

from __future__ import annotations

from gbpipe.sysid.open_loop import open_loop_method

__all__ = ["n4sid"]

n4sid = open_loop_method(
    "n4sid",
    """Identify a state-space model with N4SID (oblique projection, shift invariance).

    ``n4sid(u, y, order, horizon, dt=1.0, *, past=None, feedthrough=False, max_order=None,
    factor="auto")``

    Same arguments, result and errors as :func:`gbpipe.sysid.moesp` (``past`` is the past
    window in samples, ``>= horizon``); the two methods differ only in the weighting of the
    SVD (module docstrings).
    """,
    __name__,
)
