"""Argument checks of the subspace methods and the validated, channel-scaled record.

Every check runs before any computation and names what is wrong and what would be valid.
Bad data (NaN, lengths, too short, an all-zero channel) raise
:class:`gbpipe.errors.DataError`; bad method arguments (order, windows, sample time) raise
:class:`gbpipe.errors.ConfigError` with the argument name as ``field`` (the identification
stage passes its ``identify.*`` settings straight through). Wrong types raise ``TypeError``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gbpipe.errors import ConfigError, DataError

__all__ = [
    "PreparedData",
    "as_2d",
    "check_finite",
    "check_order",
    "check_window",
    "check_dt",
    "check_past_future",
    "is_multi",
    "channel_counts",
    "prepare",
]


@dataclass(frozen=True)
class PreparedData:
    """Validated, scaled copies of a record.

    Attributes
    ----------
    z : ndarray, shape (m + l, N), or list of them
        Scaled inputs (first ``m`` rows) and outputs (last ``l`` rows), one channel per row;
        a list (one array per record) for multi-experiment data.
    u_scale, y_scale : ndarray
        Root-mean-square value of each raw input / output channel (the scaling divisors).
    n_samples, n_inputs, n_outputs : int
    """

    z: np.ndarray | list[np.ndarray]
    u_scale: np.ndarray
    y_scale: np.ndarray
    n_samples: int
    n_inputs: int
    n_outputs: int


def as_2d(x: object, name: str) -> np.ndarray:
    """Return ``x`` as a float array of shape (samples, channels) (a view when possible).

    Raises
    ------
    TypeError
        Non-numeric or complex data.
    DataError
        More than two dimensions.
    """
    arr = np.asarray(x)
    if arr.dtype == object or not (
        np.issubdtype(arr.dtype, np.number) or arr.dtype == np.bool_
    ):
        raise TypeError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    if np.iscomplexobj(arr):
        raise TypeError(f"{name} must be real-valued; pass the real signal, not a spectrum")
    arr = arr.astype(float, copy=False)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise DataError(
            name, f"must have shape (samples,) or (samples, channels), got shape {arr.shape}"
        )
    return arr


def is_multi(x: object) -> bool:
    """Whether ``x`` holds several records: a list or tuple of numpy arrays.

    Multi-experiment data are passed as ``u = [u_0, u_1, ...]``, ``y = [y_0, y_1, ...]``
    (each ``u_i`` of shape (N_i,) or (N_i, m)); any other array-like is one record.
    """
    return isinstance(x, (list, tuple)) and len(x) > 0 and all(
        isinstance(r, np.ndarray) for r in x)


def _record_list(u: object, y: object) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(u_i, y_i)`` pairs as 2-D float arrays; one pair for single-record data."""
    if not (is_multi(u) or is_multi(y)):
        return [(as_2d(u, "u"), as_2d(y, "y"))]
    if not (is_multi(u) and is_multi(y)) or len(u) != len(y):  # type: ignore[arg-type]
        raise DataError(
            "u, y", "multi-experiment data need u and y as lists of numpy arrays of the same "
            "number of records (u = [u_0, u_1, ...], y = [y_0, y_1, ...])"
        )
    return [(as_2d(ui, f"u[{i}]"), as_2d(yi, f"y[{i}]"))
            for i, (ui, yi) in enumerate(zip(u, y, strict=True))]  # type: ignore[arg-type]


def channel_counts(u: object, y: object) -> tuple[int, int]:
    """Number of input and output channels ``(m, l)`` of one record or a list of records."""
    ua, ya = _record_list(u, y)[0]
    return ua.shape[1], ya.shape[1]


def check_finite(arr: np.ndarray, name: str) -> None:
    """Raise :class:`DataError` naming the first NaN/inf sample of ``arr`` (N, channels)."""
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = np.argwhere(bad)[0]
        raise DataError(
            name,
            f"contains NaN or inf (first in channel {idx[1]}); remove or interpolate those "
            "samples before identification",
            sample=int(idx[0]),
        )


def check_order(order: object, max_order: int, what: str) -> int | None:
    """Validate ``order`` (int or ``"auto"``); return it, or None for ``"auto"``.

    Parameters
    ----------
    order : int or "auto"
    max_order : int
        Largest order the windows allow.
    what : str
        Text naming the windows, used in the "too large" message.
    """
    if isinstance(order, str):
        if order != "auto":
            raise ConfigError("order", f"must be a positive integer or 'auto', got {order!r}")
        return None
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)):
        raise TypeError(f"order must be a positive integer or 'auto', got {order!r}")
    if order < 1:
        raise ConfigError("order", f"order must be >= 1, got {order}")
    if order > max_order:
        raise ConfigError(
            "order",
            f"order={order} is larger than the windows allow ({what} give at most "
            f"{max_order}); lower the order or lengthen the windows",
        )
    return int(order)


def check_window(value: object, name: str, minimum: int = 1) -> int:
    """Validate a window length (an integer number of samples ``>= minimum``)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer number of samples, got {value!r}")
    if value < minimum:
        raise ConfigError(name, f"{name} must be >= {minimum} samples, got {value}")
    return int(value)


def check_past_future(past: int, future: int, future_name: str) -> None:
    """Refuse ``past < future``: the past window must cover the future block rows."""
    if past < future:
        raise ConfigError(
            "past",
            f"past ({past}) must be >= {future_name} ({future}); increase past or decrease "
            f"{future_name}",
        )


def check_dt(dt: object) -> float:
    """Validate the sample time in seconds; return it as float."""
    try:
        val = float(dt)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise TypeError(f"dt must be a positive number of seconds, got {dt!r}") from None
    if not np.isfinite(val) or val <= 0:
        raise ConfigError("dt", f"dt must be a positive, finite number of seconds, got {dt!r}")
    return val


def prepare(
    u: object, y: object, *, min_samples: int, window_desc: str
) -> PreparedData:
    """Validate ``u``/``y`` and return scaled copies (the caller's arrays are never touched).

    Parameters
    ----------
    u, y : array_like, shape (N,) or (N, channels), or lists of them
        Input and output records, same number of samples, finite. Lists of numpy arrays
        (:func:`is_multi`) are several records (experiments) of the same channels; they
        share one channel scaling (the RMS value over all records).
    min_samples : int
        Smallest record length the chosen windows can use (for every record).
    window_desc : str
        Text naming the windows, used in the "record too short" message.

    Returns
    -------
    PreparedData
        ``z`` is a list when ``u`` and ``y`` are lists.

    Raises
    ------
    DataError
        NaN/inf, mismatched lengths or channels, too-short record or an all-zero channel.
    """
    pairs = _record_list(u, y)
    multi = is_multi(u)
    m, l_ = pairs[0][0].shape[1], pairs[0][1].shape[1]
    sums = [np.zeros(m), np.zeros(l_)]
    for i, (ua, ya) in enumerate(pairs):
        where = f" (record {i})" if multi else ""
        if (ua.shape[1], ya.shape[1]) != (m, l_):
            raise DataError(
                f"u[{i}], y[{i}]", f"record {i} has {ua.shape[1]} inputs and {ya.shape[1]} "
                f"outputs, record 0 has {m} and {l_}: every record needs the same channels"
            )
        if ua.shape[0] != ya.shape[0]:
            raise DataError(
                "u, y",
                f"must have the same number of samples (axis 0){where}; got u: {ua.shape[0]}, "
                f"y: {ya.shape[0]}. Pass records of equal length (time along axis 0)",
            )
        if ua.shape[0] < min_samples:
            raise DataError(
                "u, y",
                f"record too short{where}: {ua.shape[0]} samples, but {window_desc} need at "
                f"least {min_samples}; use a longer record or smaller windows",
            )
        # A NaN or inf sample makes its channel's sum of squares non-finite, so the
        # sample-by-sample search of check_finite runs only then (a finite record is read
        # once, not three times).
        for k, (name, arr) in enumerate((("u", ua), ("y", ya))):
            ss = np.einsum("ij,ij->j", arr, arr)
            if not np.all(np.isfinite(ss)):
                check_finite(arr, f"{name}[{i}]" if multi else name)
            sums[k] += ss
    n = sum(ua.shape[0] for ua, _ in pairs)
    # Channel scaling: each channel divided by its RMS value, so that badly scaled units
    # (e.g. N*m against rad/s) do not steer the SVD and the rank decisions.
    u_scale, y_scale = (np.sqrt(ss / n) for ss in sums)
    for name, sc in (("u", u_scale), ("y", y_scale)):
        zero = np.flatnonzero(sc == 0.0)
        if zero.size:
            raise DataError(
                f"{name}[{zero[0]}]",
                f"{name} channel {zero[0]} is identically zero; an identification needs "
                "every channel to carry signal: drop that channel",
            )
    zs = []
    for ua, ya in pairs:
        z = np.empty((m + l_, ua.shape[0]))
        np.divide(ua.T, u_scale[:, None], out=z[:m])
        np.divide(ya.T, y_scale[:, None], out=z[m:])
        zs.append(z)
    return PreparedData(zs if multi else zs[0], u_scale, y_scale, n, m, l_)
