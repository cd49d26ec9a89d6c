"""PO-MOESP (past-output MOESP), Verhaegen & Verdult, "Filtering and System Identification",
2007, ch. 9; the shared steps are in :mod:`gbpipe.sysid.open_loop`."""

from __future__ import annotations

from gbpipe.sysid.open_loop import identify_open_loop
from gbpipe.sysid.subspace_model import SubspaceModel

__all__ = ["moesp"]


def moesp(
    u: object,
    y: object,
    order: int | str,
    horizon: int,
    dt: float = 1.0,
    *,
    past: int | None = None,
    feedthrough: bool = False,
    max_order: int | None = None,
) -> SubspaceModel:
    """Identify a state-space model with PO-MOESP (past-output MOESP).

    The SVD is taken of ``Y_f Pi_Uf_perp Z_p'`` (the LQ block ``L32``): future outputs with the
    future inputs projected out, correlated with the past data (instrumental variable).
    Consistent for open-loop data with any coloured noise; biased in closed loop.

    Parameters
    ----------
    u : array_like, shape (N,) or (N, m)
        Input record (any unit). Not modified.
    y : array_like, shape (N,) or (N, l)
        Output record, same length. Not modified.
    order : int or "auto"
        State dimension; ``"auto"`` picks it from the singular values. At most
        ``(horizon - 1) * l``.
    horizon : int
        Future window ``f`` in samples (block rows of ``Gamma_f``), >= 2.
    dt : float
        Sample time in seconds.
    past : int, optional
        Past window (instrument) in samples, ``>= horizon``; default ``horizon``.
    feedthrough : bool
        Estimate ``D`` (default ``False``: ``D = 0``).
    max_order : int, optional
        Upper bound of the ``"auto"`` order.

    Returns
    -------
    SubspaceModel

    Raises
    ------
    DataError
        Bad data (NaN/inf, mismatched lengths, too short, an all-zero channel).
    ConfigError
        ``past < horizon`` or an order larger than the horizon allows.
    ExcitationError
        The input is not persistently exciting for the order (:mod:`.excitation`).
    """
    return identify_open_loop(u, y, order, horizon, dt, past, feedthrough, max_order, "moesp")
