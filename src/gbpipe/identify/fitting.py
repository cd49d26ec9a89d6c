"""One subspace fit of conditioned data, and its validation fit on another record.

:func:`fit_model` runs the configured method (:mod:`gbpipe.sysid`) with the configured
order (an integer, or ``"auto"`` from the singular values bounded by
``identify.max_order``) and windows; :func:`reflect_out_of_band` makes the model
simulable without touching its FRF magnitude in the band; :func:`validation_fit` scores it
on the validation record with :func:`gbpipe.lti.fit_percent`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from gbpipe import sysid
from gbpipe.lti import fit_percent

__all__ = ["METHODS", "fit_model", "fit_with_bounds", "method_arguments",
           "reflect_out_of_band", "validation_fit"]

#: Identification methods, by the name of their :mod:`gbpipe.sysid` function.
METHODS = ("pbsid", "moesp", "n4sid")


def fit_model(method: str, u: np.ndarray, y: np.ndarray, dt: float,
              s: Mapping[str, Any]) -> sysid.SubspaceModel:
    """Run one subspace method with the configured order and windows.

    PBSID takes ``past`` (VARX order) and ``future``; MOESP and N4SID take ``future`` as
    their horizon and ``past`` as the instrument window. ``D = 0`` for all three: the
    motor torque reaches no speed without dynamics, and closed-loop data bias a D estimate.
    Inputs and outputs need no scaling here: :mod:`gbpipe.sysid` divides each channel by
    its rms before the subspace steps (which would undo any constant scale applied before
    it) and returns ``B, C, D, K`` and the noise covariance in the units of ``u`` and ``y``,
    so a MIMO pairing of channels 1e4 apart in scale is fitted as well as one of equal
    scales (tests/identify/test_scaling_and_validation.py).

    Parameters
    ----------
    method : {"pbsid", "moesp", "n4sid"}
    u, y : ndarray, shape (n, m) and (n, p)
        Conditioned input and output (:func:`gbpipe.identify.condition`).
    dt : float
        Sample interval [s].
    s : mapping
        The validated ``identify`` section (``order``, ``max_order``, ``past``, ``future``,
        ``lowpass``, ``reflect_out_of_band``).

    Raises
    ------
    ValueError
        Unknown method (and the errors of :mod:`gbpipe.sysid`).
    """
    fn, kwargs = method_arguments(method, dt, s)
    return _simulable(fn(u, y, **kwargs), dt, s)


def _simulable(m: sysid.SubspaceModel, dt: float, s: Mapping[str, Any]) -> sysid.SubspaceModel:
    # the configured out-of-band reflection (identify.reflect_out_of_band), or m itself
    f_pass = float(s["lowpass"]) * 0.5 / dt
    return reflect_out_of_band(m, f_pass) if s["reflect_out_of_band"] else m


def method_arguments(method: str, dt: float, s: Mapping[str, Any]
                     ) -> tuple[Callable[..., sysid.SubspaceModel], dict[str, Any]]:
    """The :mod:`gbpipe.sysid` function of ``method`` and its keyword arguments from the
    ``identify`` section (order, windows, sample interval): one place for both the fit and
    its confidence bounds.

    Raises
    ------
    ValueError
        Unknown method.
    """
    order, max_order = s["order"], s["max_order"]
    past, fut = int(s["past"]), int(s["future"])
    if method == "pbsid":
        return sysid.pbsid, dict(order=order, past=past, future=fut, dt=dt,
                                 max_order=max_order)
    if method in ("moesp", "n4sid"):
        return getattr(sysid, method), dict(order=order, horizon=fut, dt=dt, past=past,
                                            max_order=max_order)
    raise ValueError(f"unknown method {method!r}; use {', '.join(METHODS)}")


def fit_with_bounds(method: str, u: np.ndarray, y: np.ndarray, dt: float,
                    s: Mapping[str, Any], freq: np.ndarray
                    ) -> tuple[sysid.SubspaceModel, np.ndarray, np.ndarray]:
    """:func:`fit_model` and the confidence bounds of its FRF magnitude [dB].

    The bounds are the delete-one-group jackknife of :func:`gbpipe.sysid.frf_bounds`
    (``identify.bounds.groups`` contiguous groups of the record, Student t, two-sided
    ``identify.bounds.confidence``). They measure the estimate's scatter only: a bias of
    the identification (closed-loop data for MOESP/N4SID, a finite past horizon) is not in
    them (docs/identify.md, "Confidence bounds"). The out-of-band reflection of
    :func:`reflect_out_of_band` is an all-pass change: the magnitude bounds hold for the
    returned model.

    Returns
    -------
    model : SubspaceModel
    lower_db, upper_db : ndarray, shape (len(freq), p, m)
        Bounds of ``20 log10 |G|`` [dB].
    """
    fn, kwargs = method_arguments(method, dt, s)
    b = sysid.frf_bounds(fn, u, y, freq, n_groups=int(s["bounds"]["groups"]),
                         confidence=float(s["bounds"]["confidence"]), **kwargs)
    return _simulable(b.model, dt, s), b.mag_db_lower, b.mag_db_upper


def reflect_out_of_band(model: sysid.SubspaceModel, f_pass: float) -> sysid.SubspaceModel:
    """Reflect unstable poles above the anti-aliasing pass band into the unit circle.

    The decimation filter leaves the band from ``f_pass`` [Hz] to Nyquist empty; on clean
    (noise-free) data nothing constrains poles there and the subspace step may place an
    unstable one (typically real, at z ~ -1.07). It carries no information, but it makes
    every simulation diverge. Each such pole ``z`` becomes ``1 / conj(z)`` and its residue is
    scaled by ``1 / |z|``, which leaves the magnitude of its term unchanged at every
    frequency (an all-pass factor), so the FRF magnitude in the band is untouched. In-band
    unstable poles (the true 1.3 Hz mode with one loop opened is unstable) are kept.
    """
    lam, V = np.linalg.eig(model.A)
    s_c = np.log(lam.astype(complex)) / model.dt
    bad = (np.abs(lam) > 1.0) & (np.abs(s_c) / (2 * np.pi) > f_pass)
    if not bad.any() or np.linalg.cond(V) > 1e10:
        return model
    new = lam.copy()
    new[bad] = 1.0 / np.conj(lam[bad])
    scale = np.ones(lam.size, dtype=complex)
    scale[bad] = 1.0 / np.abs(lam[bad])
    Vi = np.linalg.inv(V)
    a = (V @ np.diag(new) @ Vi).real
    b = (V @ np.diag(scale) @ Vi @ model.B).real
    return replace(model, A=a, B=b, info={**model.info, "reflected_poles": int(bad.sum())})


def validation_fit(model: sysid.SubspaceModel, u: np.ndarray, y: np.ndarray,
                   segment: int) -> np.ndarray:
    """Simulation fit [%] per output on a validation record, in segments.

    The record is cut into segments of ``segment`` samples; each is simulated from its own
    least-squares initial state and the simulations are joined; the fit is
    :func:`gbpipe.lti.fit_percent` over the whole record. Segments, because the true model
    from a torque to a speed is not stable on its own (rigid-body integrator; with only one
    loop closed the 1.3 Hz motor-against-motor mode is even unstable): a single 40 s
    simulation of even a very good model drifts away, which says nothing about its
    dynamics. The result is that of
    :meth:`~gbpipe.sysid.SubspaceModel.estimate_x0` and
    :meth:`~gbpipe.sysid.SubspaceModel.simulate` per segment, computed in one pass
    (:meth:`~gbpipe.sysid.SubspaceModel.simulate_segments`).

    Returns
    -------
    ndarray, shape (p,)
        Fit per output [%]; NaN where it is not finite (a model that fails to simulate, a
        NaN in the record): the caller counts such a fit as a failure.
    """
    segment = max(2 * model.order, min(segment, len(u)))
    with np.errstate(all="ignore"):
        try:
            y_sim, _ = model.simulate_segments(u, y, segment)
        except (ValueError, np.linalg.LinAlgError):
            return np.full(y.shape[1], np.nan)
        fit = fit_percent(y, y_sim)
    return np.where(np.isfinite(fit), fit, np.nan)
