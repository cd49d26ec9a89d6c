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
    their horizon and ``past`` as the instrument window. ``D`` is estimated when
    ``identify.feedthrough`` (the default): a continuous system has no direct term, but its
    decimated, band-limited record does (the causal anti-aliasing FIR leaves a response at
    lag 0). With ``D = 0`` a noise-free fit imitates that term with spurious poles far
    outside the unit circle (``z = -20.9`` on a clean torque-meter record); with noise it
    cannot, and the magnitude is biased upward at high frequency: +1.4 dB at 250 Hz for
    driven torque -> driven torque meter, mean of 3 random-only ms_torque records with the
    torque meter's 10 N m noise, against +-0.04 dB from 15 to 350 Hz with ``D``
    estimated (docs/identify.md).

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
    # the configured reflection (identify.reflect_out_of_band), or m itself; an unstable
    # pole damped beyond identify.zeta_max (not a mode) is reflected in band too
    f_pass = float(s["lowpass"]) * 0.5 / dt
    return reflect_out_of_band(m, f_pass, float(s["zeta_max"])) if s["reflect_out_of_band"] else m


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
    # identify.factor: "ridge" on the decimated records, whose Gram matrices are singular
    # (an empty stop band) and whose noise may be process noise only (docs/identify.md)
    common = dict(order=order, dt=dt, max_order=max_order, factor=s["factor"],
                  feedthrough=bool(s["feedthrough"]))
    if method == "pbsid":
        return sysid.pbsid, dict(common, past=past, future=fut)
    if method in ("moesp", "n4sid"):
        return getattr(sysid, method), dict(common, horizon=fut, past=past)
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
    :func:`reflect_out_of_band` keeps the in-band FRF (its B is refitted to it): the
    magnitude bounds hold for the returned model.

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


def reflect_out_of_band(model: sysid.SubspaceModel, f_pass: float,
                        zeta_max: float | None = None,
                        n_grid: int = 1000) -> sysid.SubspaceModel:
    """Reflect unstable poles above the anti-aliasing pass band into the unit circle
    (and, with ``zeta_max``, in-band unstable poles damped more negatively than
    ``-zeta_max``).

    The decimation filter leaves the band from ``f_pass`` [Hz] to Nyquist empty; on clean
    (noise-free) data nothing constrains poles there and the subspace step may place
    unstable ones (typically real, at z ~ -1.1 ... -20). They carry no information, but
    they make every simulation diverge. Each such pole ``z`` becomes ``1 / conj(z)``, and
    ``B`` and ``D`` are then refitted by linear least squares so that the new model's FRF
    matches the old one on ``n_grid`` frequencies of the pass band, each element in
    *relative* terms (weighted by ``1 / |G|``: a dB error is what is minimised). Moving a
    pole alone is not enough: an out-of-band pole far outside the unit circle shapes the
    in-band response through its residue, and reflecting it with a rescaled residue kept
    only that term's magnitude, not the sum's: 2-7 dB off at 270-350 Hz on a clean
    torque-meter record. ``A``'s other poles, ``C`` and ``K`` are kept; in-band unstable
    poles (the true 1.3 Hz mode with one loop opened is unstable, zeta = -0.023) are kept
    too, unless ``zeta_max`` is given and ``zeta < -zeta_max``: no bench mode grows by
    ``e`` within a few periods. The ridged factor route (``identify.factor``) placed such a
    pair at 314 Hz, ``|z| = 2.3``, ``zeta = -0.42``, on the clean ms_torque record
    (Tdrn -> wdrn): its FRF matched the truth to 350 Hz but every simulation diverged;
    reflected and refitted, the FRF stays within 0.34 dB and the validation fit is 90.9 %.
    """
    lam, V = np.linalg.eig(model.A)
    s_c = np.log(lam.astype(complex)) / model.dt
    bad = np.abs(s_c) / (2 * np.pi) > f_pass
    if zeta_max is not None:
        bad |= s_c.real > zeta_max * np.abs(s_c)  # zeta = -Re(s) / |s| < -zeta_max
    bad &= np.abs(lam) > 1.0
    if not bad.any() or np.linalg.cond(V) > 1e10:
        return model
    new = lam.copy()
    new[bad] = 1.0 / np.conj(lam[bad])
    vi = np.linalg.inv(V)
    a = (V @ np.diag(new) @ vi).real
    # the pass band, from just above 0 Hz (a rigid-body pole at z = 1 is infinite there)
    f = np.linspace(f_pass / n_grid, f_pass, n_grid)
    g_old = model.frf(f)  # (n_f, p, m)
    z = np.exp(2j * np.pi * f * model.dt)
    n = a.shape[0]
    # regressor of B: C (z I - A_new)^-1 = (C V) diag(1 / (z - new)) V^-1, shape
    # (n_f, p, n), in the eigenbasis (V is well conditioned: checked above); the FRF is
    # linear in B
    phi = ((model.C @ V)[None] / (z[:, None] - new[None, :])[:, None, :]) @ vi
    w = 1.0 / np.maximum(np.abs(g_old), np.finfo(float).tiny)  # relative error per element
    p_out = phi.shape[1]
    # D's regressor: output i's own column (a pole far outside the circle, e.g. z = -20,
    # is an almost constant term in the band, which its reflection at -0.05 is not)
    eye = np.broadcast_to(np.eye(p_out), (f.size, p_out, p_out))
    reg = np.concatenate([phi, eye], axis=2)
    b, d = np.empty_like(model.B), np.empty_like(model.D)
    for j in range(model.B.shape[1]):
        lhs = (w[:, :, j, None] * reg).reshape(-1, n + p_out)
        rhs = (w[:, :, j] * g_old[:, :, j]).ravel()
        x = np.linalg.lstsq(np.concatenate([lhs.real, lhs.imag]),
                            np.concatenate([rhs.real, rhs.imag]), rcond=None)[0]
        b[:, j], d[:, j] = x[:n], x[n:]
    return replace(model, A=a, B=b, D=d, info={**model.info, "reflected_poles": int(bad.sum())})


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
