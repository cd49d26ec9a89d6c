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
    "prepare",
]


@dataclass(frozen=True)
class PreparedData:
    """Validated, scaled copies of a record.

    Attributes
    ----------
    z : ndarray, shape (m + l, N)
        Scaled inputs (first ``m`` rows) and outputs (last ``l`` rows), one channel per row.
    u_scale, y_scale : ndarray
        Root-mean-square value of each raw input / output channel (the scaling divisors).
    n_samples, n_inputs, n_outputs : int
    """

    z: np.ndarray
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
    u, y : array_like, shape (N,) or (N, channels)
        Input and output records, same number of samples, finite.
    min_samples : int
        Smallest record length the chosen windows can use.
    window_desc : str
        Text naming the windows, used in the "record too short" message.

    Returns
    -------
    PreparedData

    Raises
    ------
    DataError
        NaN/inf, mismatched lengths, too-short record or an all-zero channel.
    """
    ua = as_2d(u, "u")
    ya = as_2d(y, "y")
    if ua.shape[0] != ya.shape[0]:
        raise DataError(
            "u, y",
            f"must have the same number of samples (axis 0); got u: {ua.shape[0]}, "
            f"y: {ya.shape[0]}. Pass records of equal length (time along axis 0)",
        )
    n = ua.shape[0]
    if n < min_samples:
        raise DataError(
            "u, y",
            f"record too short: {n} samples, but {window_desc} need at least {min_samples}; "
            "use a longer record or smaller windows",
        )
    # Channel scaling: each channel divided by its RMS value, so that badly scaled units
    # (e.g. N*m against rad/s) do not steer the SVD and the rank decisions. A NaN or inf
    # sample makes its channel's sum of squares non-finite, so the sample-by-sample search
    # of check_finite runs only then (a finite record is read once, not three times).
    sums = []
    for name, arr in (("u", ua), ("y", ya)):
        ss = np.einsum("ij,ij->j", arr, arr)
        if not np.all(np.isfinite(ss)):
            check_finite(arr, name)
        sums.append(ss)
    u_scale, y_scale = (np.sqrt(ss / n) for ss in sums)
    for name, sc in (("u", u_scale), ("y", y_scale)):
        zero = np.flatnonzero(sc == 0.0)
        if zero.size:
            raise DataError(
                f"{name}[{zero[0]}]",
                f"{name} channel {zero[0]} is identically zero; an identification needs "
                "every channel to carry signal: drop that channel",
            )
    z = np.empty((ua.shape[1] + ya.shape[1], n))
    np.divide(ua.T, u_scale[:, None], out=z[: ua.shape[1]])
    np.divide(ya.T, y_scale[:, None], out=z[ua.shape[1]:])
    return PreparedData(z, u_scale, y_scale, n, ua.shape[1], ya.shape[1])
