"""Whether a truth mode of a random chain is in its record at all, and why a tool missed it.

Shared by ``benchmarks/modal_selection.py``. Two figures per truth mode, from the case's
true plant and the record (nothing of gbpipe's result):

* **modal SNR**: the mode's own peak in the output PSD over the record's noise PSD there,
  the larger over the outputs. The mode's own FRF term is ``r / (i w - s) + conj`` with
  the residue ``r = (C phi)(psi^T B)`` of its pole ``s`` (right and left eigenvectors of
  the continuous state matrix: the mode shape at the sensor times its participation at
  the input), evaluated at the damped peak ``f sqrt(1 - 2 zeta^2)`` and driven by the
  measured motor torque's Welch PSD; the noise is the output PSD not coherent with the
  measured input, ``(1 - gamma^2) S_yy`` (sensor noise, input noise, unmeasured order
  torque), same Welch segments. Below 1 the mode's own peak lies under the noise at its
  own frequency: no fit separates it from the noise of a record this long, whatever its
  selection (the per-line noise of the PSD estimate is already averaged over the Welch
  segments that set the resolution every method works at).
* **modal overlap**: the spacing to the nearest other mode over the sum of the two
  half-power half-widths ``zeta_k f_k + zeta_j f_j``; below 1 the two modes overlap inside
  their half-power bands (one peak in the spectrum).

A truth mode in the coherent band is **detectable** when its modal SNR is at least 1.
:func:`miss_reason` says, for a detectable mode a diagram missed, where in the selection
it was lost, from the diagram's poles as ``record_modes`` writes them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.signal


def modal_snr(plant: tuple, f_modes: np.ndarray, zeta: np.ndarray, u: np.ndarray,
              ys: list[np.ndarray], fs: float, segment: float) -> np.ndarray:
    """Modal SNR of each mode (module docstring) [1].

    Parameters
    ----------
    plant : (A, B, C, D)
        Continuous plant; input 0 the measured input, outputs ``0 .. len(ys) - 1`` the
        measured ones.
    f_modes, zeta : ndarray
        The modes' natural frequencies [Hz] and damping ratios [1].
    u, ys : ndarray
        Measured input and outputs of the record, any units (those of the plant).
    fs : float
        Sample rate [Hz].
    segment : float
        Welch segment [s] (Hann, 50 % overlap).
    """
    a, b, c, _ = plant
    lam, v = np.linalg.eig(a)
    w = np.linalg.inv(v)  # rows: left eigenvectors, scaled to w v = I
    n = int(round(segment * fs))
    f, puu = scipy.signal.welch(u, fs=fs, nperseg=n)
    noise = []
    for y in ys:
        _, pyy = scipy.signal.welch(y, fs=fs, nperseg=n)
        _, coh = scipy.signal.coherence(u, y, fs=fs, nperseg=n)
        noise.append((1.0 - coh) * pyy)
    out = np.zeros(f_modes.size)
    for k, (fk, zk) in enumerate(zip(f_modes, zeta, strict=True)):
        s = 2 * np.pi * fk * (-zk + 1j * np.sqrt(1 - zk**2))
        i = int(np.argmin(np.abs(lam - s)))
        fp = fk * np.sqrt(max(1 - 2 * zk**2, 0.0))  # the peak of a displacement-like term
        jw = 2j * np.pi * fp
        for o, pn in enumerate(noise):
            r = (c[o] @ v[:, i]) * (w[i] @ b[:, 0])
            h = r / (jw - lam[i]) + np.conj(r) / (jw - np.conj(lam[i]))
            peak = np.abs(h) ** 2 * np.interp(fp, f, puu)
            out[k] = max(out[k], peak / max(float(np.interp(fp, f, pn)), 1e-300))
    return out


def modal_overlap(f_modes: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """Spacing to the nearest mode over the sum of the half-power half-widths [1]
    (``inf`` for a single mode)."""
    half = zeta * f_modes
    out = np.full(f_modes.size, np.inf)
    for k in range(f_modes.size):
        other = np.arange(f_modes.size) != k
        if other.any():
            out[k] = np.min(np.abs(f_modes[other] - f_modes[k]) / (half[k] + half[other]))
    return out


def miss_reason(d: Any, f: float, tol: float, matched: bool) -> str:
    """Where a diagram lost a truth mode at ``f`` [Hz] (tolerance ``tol`` [Hz]).

    ``d``: one method and pairing of ``record_modes``' dataset. ``matched``: a ``mode``
    row within the tolerance went to another truth mode (the nearest). In order: a row of
    another kind (its kind, and the order line it lies on), no pole within the tolerance
    at any order, poles but stable at fewer than 3 orders (frequency, damping or MAC
    change between orders), stable at 3 or more but no cluster kept (the size rule).
    """
    rows = np.isfinite(d.mode_frequency.values) & (np.abs(d.mode_frequency.values - f) <= tol)
    if matched:
        return "its row matched a nearer truth mode"
    if rows.any():
        k = int(np.flatnonzero(rows)[0])
        line = float(d.mode_line_order.values[k])
        on = f" (order {line:g})" if np.isfinite(line) else ""
        return f"row labelled {d.mode_kind.values[k]}{on}"
    near = np.abs(d.pole_frequency.values - f) <= tol  # (order, pole); NaN compares False
    orders = d.order.values[np.isfinite(d.order.values)]
    held = near.any(axis=1)[:orders.size]
    if not held.any():
        return f"no pole at any order {int(orders[0])}-{int(orders[-1])}"
    stable = (near & (d.pole_stable.values > 0)).any(axis=1)[:orders.size]
    first = int(orders[np.argmax(held)])
    if stable.sum() < 3:
        return (f"poles at {held.sum()} orders from {first}, stable at {stable.sum()} "
                "(frequency/damping/MAC change)")
    return f"poles at {held.sum()} orders from {first}, stable at {stable.sum()}: no cluster"
