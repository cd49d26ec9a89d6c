"""One subspace fit of conditioned data, and its validation fit on another record.

:func:`fit_model` runs the configured method (:mod:`gbpipe.sysid`) with the configured
order (an integer, or ``"auto"`` from the singular values bounded by
``identify.max_order``) and windows; :func:`reflect_out_of_band` makes the model
simulable without touching its FRF magnitude in the band; :func:`validation_fit` scores it
on the validation record with :func:`gbpipe.lti.fit_percent`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np
from scipy import fft

from gbpipe import sysid
from gbpipe.lti import fit_percent

__all__ = ["METHODS", "fit_model", "reflect_out_of_band", "validation_fit",
           "segment_simulation", "free_responses"]

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
    order, max_order = s["order"], s["max_order"]
    past, fut = int(s["past"]), int(s["future"])
    if method == "pbsid":
        m = sysid.pbsid(u, y, order, past, fut, dt=dt, max_order=max_order)
    elif method in ("moesp", "n4sid"):
        m = getattr(sysid, method)(u, y, order, fut, dt, past=past, max_order=max_order)
    else:
        raise ValueError(f"unknown method {method!r}; use {', '.join(METHODS)}")
    f_pass = float(s["lowpass"]) * 0.5 / dt
    return reflect_out_of_band(m, f_pass) if s["reflect_out_of_band"] else m


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
    (:func:`segment_simulation`).

    Returns
    -------
    ndarray, shape (p,)
        Fit per output [%]; NaN where it is not finite (a model that fails to simulate, a
        NaN in the record): the caller counts such a fit as a failure.
    """
    segment = max(2 * model.order, min(segment, len(u)))
    with np.errstate(all="ignore"):
        try:
            y_sim = segment_simulation(model, u, y, segment)
        except (ValueError, np.linalg.LinAlgError):
            return np.full(y.shape[1], np.nan)
        fit = fit_percent(y, y_sim)
    return np.where(np.isfinite(fit), fit, np.nan)


def segment_simulation(model: sysid.SubspaceModel, u: np.ndarray, y: np.ndarray,
                       segment: int) -> np.ndarray:
    """Simulation of ``u`` restarted every ``segment`` samples from the least-squares state.

    Per segment, the output from the least-squares initial state is ``y0 + P (y - y0)``:
    ``y0`` the response from zero state and ``P`` the orthogonal projection onto the span
    of the free responses ``C A^k`` (what :func:`numpy.linalg.lstsq` fits in
    :meth:`~gbpipe.sysid.SubspaceModel.estimate_x0`). The free responses also give the
    Markov parameters ``D, C B, C A B, ...``, so the zero-state responses of all segments
    are one batched FFT convolution (:mod:`scipy.fft`), and every segment
    of the same length shares one projection (one SVD): no simulation per segment. Both
    are exact up to rounding relative to the largest free response, as the least-squares
    fit per segment is.

    Parameters
    ----------
    model : gbpipe.sysid.SubspaceModel
    u, y : ndarray, shape (n, m) and (n, p)
        Validation input and output [model units].
    segment : int
        Segment length [samples]; a last segment shorter than the model order is copied
        from ``y`` (too short to estimate a state).

    Returns
    -------
    ndarray, shape (n, p)
        Joined segment simulations; non-finite where the model's response overflows.
    """
    if model.order == 0:  # no state to estimate
        return model.simulate(u)
    free = free_responses(model.A, model.C, segment)
    markov = np.concatenate([model.D[None], free[:-1] @ model.B])  # (segment, p, m)
    y_sim = np.empty_like(y)
    for length, starts in _segments(len(u), segment).items():
        if length < model.order:  # too short to estimate a state: keep the record
            y_sim[starts[0]:] = y[starts[0]:]
            continue
        idx = np.asarray(starts)[None, :] + np.arange(length)[:, None]  # (length, segs)
        u_seg, y_seg = u[idx], y[idx]
        # zero-state responses: the matrix-valued convolution with the Markov parameters,
        # a product per frequency of the zero-padded transforms (no wrap-around)
        nfft = fft.next_fast_len(2 * length, real=True)
        y0 = fft.irfft(np.einsum("fsm,fpm->fsp", fft.rfft(u_seg, nfft, axis=0),
                                 fft.rfft(markov[:length], nfft, axis=0)), nfft,
                       axis=0)[:length]
        q = _free_basis(free[:length])
        # residuals of all segments of this length as columns, projected at once
        r = (y_seg - y0).transpose(0, 2, 1).reshape(-1, len(starts))
        y_sim[idx] = y0 + (q @ (q.T @ r)).reshape(length, -1, len(starts)).transpose(0, 2, 1)
    return y_sim


def free_responses(a: np.ndarray, c: np.ndarray, n_samples: int) -> np.ndarray:
    """Free responses ``out[k] = C A^k`` for ``k < n_samples``, shape (n_samples, p, n).

    By doubling: ``out[k:2k] = out[:k] A^k`` with ``A^k`` squared each step, so about
    ``log2(n_samples)`` batched products instead of one simulation per output
    (:func:`gbpipe.sysid.subspace_model.free_response`, which it matches to rounding). An
    unstable model's responses overflow to inf, as a simulation's would.
    """
    out = np.empty((n_samples, c.shape[0], a.shape[0]))
    out[0] = c
    k, a_k = 1, a
    with np.errstate(over="ignore", invalid="ignore"):
        while k < n_samples:
            step = min(k, n_samples - k)
            out[k:k + step] = out[:step] @ a_k
            k, a_k = k + step, a_k @ a_k
    return out


def _segments(n: int, segment: int) -> dict[int, list[int]]:
    # start samples of the segments of range(n), grouped by length (the last may be shorter)
    out: dict[int, list[int]] = {}
    for s in range(0, n, segment):
        out.setdefault(min(segment, n - s), []).append(s)
    return out
def _free_basis(free: np.ndarray) -> np.ndarray:
    # orthonormal basis of the free responses (shape (L, p, n) -> (L p, rank)), with the
    # rank cut of numpy.linalg.lstsq (rcond = eps max(rows, cols)); an overflowing free
    # response gives a non-finite basis, hence a non-finite simulation (a failed fit)
    phi = free.reshape(-1, free.shape[-1])
    if not np.all(np.isfinite(phi)):
        return np.full((phi.shape[0], 1), np.nan)
    uu, sv, _ = np.linalg.svd(phi, full_matrices=False)
    keep = sv > np.finfo(float).eps * max(phi.shape) * sv[0]
    return uu[:, keep]
