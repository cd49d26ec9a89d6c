"""PO-MOESP (past-output MOESP), Verhaegen & Verdult, "Filtering and System Identification",
2007, ch. 9; the shared steps and the signature are in :mod:`gbpipe.sysid.open_loop`."""

from __future__ import annotations

from gbpipe.sysid.open_loop import open_loop_method

__all__ = ["moesp"]

moesp = open_loop_method(
    "moesp",
    """Identify a state-space model with PO-MOESP (past-output MOESP).

    ``moesp(u, y, order, horizon, dt=1.0, *, past=None, feedthrough=False, max_order=None,
    factor="auto")``

    The SVD is taken of ``Y_f Pi_Uf_perp Z_p'`` (the LQ block ``L32``): future outputs with the
    future inputs projected out, correlated with the past data (instrumental variable).
    Consistent for open-loop data with any coloured noise; biased in closed loop.

    Parameters
    ----------
    u : array_like, shape (N,) or (N, m), or list of arrays
        Input record (any unit). Not modified. Several records (experiments) as a list of
        numpy arrays ``[u_0, u_1, ...]``: each keeps its own initial state and no window
        straddles two records.
    y : array_like, shape (N,) or (N, l), or list of arrays
        Output record(s), same lengths. Not modified.
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
    factor : {"auto", "ridge", "gram", "qr"}
        Route to the triangular factor of the data windows
        (:func:`gbpipe.sysid.hankel.window_r_factor`); ``"auto"`` by default.

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
    """,
    __name__,
)
