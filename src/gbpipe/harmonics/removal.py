"""Harmonic-removal methods side by side, behind one signature.

:data:`METHODS` maps a method name (the config's ``removal.method``) to a function

    f(x, fs, pulse_times, families, pulses_per_rev=1, *, t0=0.0, method="pchip",
      **params) -> residual

modelled on :func:`gbpipe.harmonics.residual_joint`: a record (any unit) sampled at
``fs`` [Hz], the HSS tachometer pulse times [s], the order families to remove (name ->
orders [HSS orders], as :func:`gbpipe.harmonics.excitation_families` gives them), and the
residual of the same length (samples outside the pulse span unchanged). ``params`` are the
method's own keyword arguments.

=============  =========================================================================
``tsa``        time-synchronous averaging (:mod:`gbpipe.harmonics.tsa`, unchanged): one
               cycle per family, the greatest common divisor of its orders; removes every
               harmonic of that cycle, not only the listed orders
``vkf``        Vold-Kalman order tracking filter (:mod:`gbpipe.harmonics.vkf`)
``regression`` angle-domain least-squares regression (:mod:`gbpipe.harmonics.regression`)
``drs``        discrete/random separation (:mod:`gbpipe.harmonics.drs`)
``cepstrum``   cepstral editing (:mod:`gbpipe.harmonics.cepstrum`)
=============  =========================================================================
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from fractions import Fraction
from typing import Literal

import numpy as np

from gbpipe.harmonics.cepstrum import residual_cepstrum
from gbpipe.harmonics.drs import residual_drs
from gbpipe.harmonics.joint import residual_joint
from gbpipe.harmonics.regression import residual_regression
from gbpipe.harmonics.removal_inputs import Families, family_cycle, family_orders_checked
from gbpipe.harmonics.tacho import AngleMethod
from gbpipe.harmonics.tsa import residual
from gbpipe.harmonics.vkf import residual_vkf

__all__ = ["METHODS", "MULTICHANNEL", "GROUP_BYTES", "RemovalMethod", "channel_groups",
           "family_cycles", "residual_tsa", "remove_harmonics"]

#: A removal method: ``f(x, fs, pulse_times, families, pulses_per_rev=1, **params)``.
RemovalMethod = Callable[..., np.ndarray]


def family_cycles(families: Families) -> list[Fraction]:
    """The TSA cycles that remove the families: each family's fundamental, without the
    cycles that are whole multiples of another (its harmonics are already removed)."""
    family_orders_checked(families)
    cycles = sorted({family_cycle(list(o)) for o in families.values()})
    return [c for c in cycles if not any(d != c and (c / d).denominator == 1 for d in cycles)]


def residual_tsa(
    x: np.ndarray,
    fs: float,
    pulse_times: np.ndarray,
    families: Families,
    pulses_per_rev: int = 1,
    *,
    n_cycles: int = 10,
    averaging: Literal["block", "sliding", "quadratic"] = "block",
    unbiased: bool = False,
    mode: Literal["joint", "cascade"] = "joint",
    t0: float = 0.0,
    method: AngleMethod = "pchip",
) -> np.ndarray:
    """TSA residual of the families' cycles (:func:`family_cycles`), by
    :func:`gbpipe.harmonics.residual` or, for several, :func:`gbpipe.harmonics.residual_joint`.

    Parameters are those of :func:`gbpipe.harmonics.residual_joint`; ``families`` as in
    :data:`METHODS`.
    """
    cycles = family_cycles(families)
    opts = dict(unbiased=unbiased, averaging=averaging, t0=t0, method=method)
    if len(cycles) == 1:
        return residual(x, fs, pulse_times, cycles[0], n_cycles, pulses_per_rev, **opts)
    return residual_joint(x, fs, pulse_times, cycles, n_cycles, pulses_per_rev, mode=mode,
                          **opts)


#: Removal methods by name (module table).
METHODS: dict[str, RemovalMethod] = {
    "tsa": residual_tsa,
    "vkf": residual_vkf,
    "regression": residual_regression,
    "drs": residual_drs,
    "cepstrum": residual_cepstrum,
}


#: Methods that take the channels of one record at once, ``x`` of shape (n, channels), or
#: of several records of one angle, (records, n, channels): their work on the angle
#: (regressors, factors) is shared by the channels.
MULTICHANNEL = frozenset({"regression"})

#: Bytes of float64 that a group of channels removed in one call may hold in
#: :func:`gbpipe.harmonics.split_residuals`' one array of them (the signals, whose
#: residuals replace them: ``overwrite_x``). An hour's 8 channels at 5 kHz hold 1.15 GB,
#: one group (the regression's work on a piece adds about 0.9 GB); two hours' go in two.
GROUP_BYTES = 3 * 2**29


def channel_groups(method: str, names: Sequence[str], values: int) -> list[list[str]]:
    """The channels of a record removed in one call each.

    Parameters
    ----------
    method : str
        A name of :data:`METHODS`.
    names : sequence of str
        The channels.
    values : int
        Samples of one channel, times the records removed with it.

    Returns
    -------
    list of list of str
        A :data:`MULTICHANNEL` method's channels in groups whose array fits
        :data:`GROUP_BYTES` (each channel's result is the one it has alone, so the groups
        change the memory and the shared work, not the result); any other's one by one.
    """
    if method not in MULTICHANNEL:
        return [[name] for name in names]
    size = max(1, GROUP_BYTES // (8 * max(int(values), 1)))
    return [list(names[i:i + size]) for i in range(0, len(names), size)]


def remove_harmonics(name: str, x: np.ndarray, fs: float, pulse_times: np.ndarray,
                     families: Families, pulses_per_rev: int = 1, *,
                     overwrite_x: bool = False, **params) -> np.ndarray:
    """Residual of ``x`` after removal of ``families`` by the method ``name``.

    Parameters
    ----------
    name : {"tsa", "vkf", "regression", "drs", "cepstrum"}
        Method (:data:`METHODS`).
    x : array_like, shape (n,), (n, channels) or (records, n, channels)
        Record (any unit, e.g. N m), sample ``i`` at ``t0 + i / fs``; several channels
        of one record (one pulse train) as columns; several records of one time base and
        pulse train (a record and its harmonic part) along the first axis. Not modified
        unless ``overwrite_x``.
    fs : float
        Sample rate [Hz].
    pulse_times : array_like
        Tachometer pulse times of the HSS [s], within the record.
    families : mapping str -> sequence of float or Fraction
        Orders [HSS orders] of each family to remove (e.g.
        :func:`gbpipe.harmonics.excitation_families`).
    pulses_per_rev : int
        Tachometer pulses per HSS revolution.
    overwrite_x : bool
        ``x`` may be overwritten by the residual: a :data:`MULTICHANNEL` method then
        holds a record's channels once (their residual is returned in ``x``'s memory);
        the others, which take one channel at a time, return a new array.
    **params
        The method's keyword arguments (e.g. ``bandwidth`` for ``vkf``), and ``t0``, the
        time of the first sample [s] (default 0), and ``method``, the angle interpolation
        between pulses (``"pchip"`` default, ``"cubic"``, ``"linear"``).

    Returns
    -------
    numpy.ndarray
        The residual, in the unit of ``x`` and of its shape; samples outside the pulse
        span (no angle) are returned unchanged. Each channel's residual is that of the
        channel alone (:data:`MULTICHANNEL` methods share their work, others take the
        columns one by one).

    Raises
    ------
    DataError, PulseError
        A bad record or pulse train (as :func:`gbpipe.harmonics.resample_to_angle`).
    ValueError
        Unknown method, or a bad parameter of the method.
    TypeError
        A parameter the method does not take.
    """
    if name not in METHODS:
        raise ValueError(f"removal method {name!r} is unknown: use one of {sorted(METHODS)}")
    xa = np.asarray(x, dtype=float)
    if xa.ndim == 3 and name not in MULTICHANNEL:
        return np.stack([remove_harmonics(name, r, fs, pulse_times, families,
                                          pulses_per_rev, **params) for r in xa])
    if xa.ndim == 2 and name not in MULTICHANNEL:
        return np.column_stack([METHODS[name](xa[:, j], fs, pulse_times, families,
                                              pulses_per_rev, **params)
                                for j in range(xa.shape[1])])
    if name in MULTICHANNEL:
        params = {**params, "overwrite_x": overwrite_x}
    return METHODS[name](xa, fs, pulse_times, families, pulses_per_rev, **params)
