"""Poly-reference least-squares complex frequency-domain estimator (LSCF, PolyMAX-style).

The FRF matrix is modelled as a right matrix fraction with a common denominator,
``H(z) = B(z) A(z)^(-1)``, ``A(z) = sum_j alpha_j z^j`` (m x m blocks, m inputs) and
``B_o(z) = sum_j beta_oj z^j`` per output, on the z-domain basis ``z = exp(i 2 pi f dt)``
(Guillaume, Verboven, Vanlanduit, Van der Auweraer & Peeters, "A poly-reference
implementation of the least-squares complex frequency-domain estimator", IMAC 21, 2003;
Peeters, Van der Auweraer, Guillaume & Leuridan, "The PolyMAX frequency-domain method: a
new standard for modal parameter estimation?", Shock and Vibration 11, 2004).

The linearised equations ``B_o(z_k) - H_o(z_k) A(z_k) = 0`` are solved in least squares
with ``alpha_n = I`` after eliminating the numerators, the reduction PolyMAX writes with
the normal matrices ``M = 2 sum_o (T_o - S_o' R_o^(-1) S_o)``; here it is done on the
triangular factor of each output's equations (the same solution without squaring their
condition number). The factors are built once at the highest order and, the basis being
nested, every lower order reads its reduced equations off them, so a stabilization diagram
costs one pass over the data. The poles are the eigenvalues of the block companion matrix
of ``A``; its eigenvectors' first block is the modal participation vector (one entry per
input), the shape the stabilization test compares (:mod:`.stabilization`).
"""

from __future__ import annotations

import numpy as np

from gbpipe.errors import ConfigError, DataError
from gbpipe.sysid.checks import check_dt
from gbpipe.sysid.stabilization import (
    Stabilization,
    check_criteria,
    check_orders,
    continuous_poles,
    stabilize,
)

__all__ = ["lscf_poles", "lscf_stabilization"]


def lscf_poles(frequency_hz: object, frf: object, orders: object, sample_time: float,
               weights: object = None) -> list[tuple[np.ndarray, np.ndarray]]:
    """Discrete poles and participation vectors of the poly-reference LSCF per order.

    Parameters
    ----------
    frequency_hz : array_like, shape (F,)
        Frequencies of the FRF [Hz], strictly increasing, in ``[0, 1 / (2 sample_time)]``.
    frf : array_like, complex, shape (F, outputs, inputs) or (F,)
        Nonparametric FRF (any units, e.g. ``(rad/s)/(N·m)``).
    orders : sequence of int
        Polynomial orders ``n`` (each gives ``n * inputs`` poles), strictly increasing.
    sample_time : float
        Sample time ``dt`` of the z-domain basis [s], normally that of the record.
    weights : array_like, shape (F,) or (F, outputs), optional
        Non-negative weight of each line (e.g. the inverse standard deviation of the FRF
        estimate, or 0 outside a coherent band). Default: each output weighted by the
        inverse RMS magnitude of its FRF, so that outputs in different units count alike.

    Returns
    -------
    list of (z, participation)
        Per order: eigenvalues ``z`` (n m,) of the companion matrix, complex, and the
        participation vectors as columns (inputs, n m).

    Raises
    ------
    DataError
        Shapes, non-finite values, frequencies not increasing or above Nyquist, bad weights.
    ConfigError
        Bad ``orders`` or ``sample_time``; an order that needs more lines than the FRF has.
    """
    f, h, w, dt = _checked(frequency_hz, frf, weights, sample_time)
    orders = check_orders(orders)
    n_freq, n_out, n_in = h.shape
    n_max = int(orders[-1])
    if n_freq * n_out <= (n_max + 1) * n_in or n_freq <= n_max:
        raise ConfigError("orders", f"order {n_max} needs more than {n_max + 1} frequency "
                          f"lines with {n_in} input(s); the FRF has {n_freq}: lower the "
                          "orders or pass a finer FRF")
    x = np.exp(1j * 2 * np.pi * f[:, None] * dt * np.arange(n_max + 1))  # (F, n + 1)
    # Square-root form: the R factor of each output's real-stacked equations, numerator
    # columns (one per power j) first, then the denominator columns (j, input). The
    # normal equations, which square the condition number (1e14 for 12 poles near z = 1),
    # are never formed.
    p1 = n_max + 1
    factors = []
    for o in range(n_out):
        xw = x * w[:, o, None]
        y = -(xw[:, :, None] * h[:, o, None, :]).reshape(n_freq, -1)  # column (j, input)
        cols = np.hstack([xw, y])
        factors.append(np.linalg.qr(np.vstack([cols.real, cols.imag]), mode="r"))
    out = []
    for n in orders:
        c = (n + 1) * n_in
        # Order n's numerator spans the first n + 1 orthonormal directions of the nested
        # basis; what of its denominator columns lies outside them is, in that orthonormal
        # frame, the rows n + 1.. of the coupling block and the rows of the lower block.
        rows = [np.vstack([r[n + 1: p1, p1: p1 + c], r[p1: p1 + c, p1: p1 + c]])
                for r in factors]
        ra = np.vstack(rows)  # alpha columns (j, input), j = 0..n
        nm = n * n_in
        alpha = np.linalg.lstsq(ra[:, :nm], -ra[:, nm:], rcond=None)[0]  # alpha_0..n-1
        comp = np.zeros((nm, nm))
        comp[:-n_in, n_in:] = np.eye(nm - n_in)
        # Last block row [-alpha_0, ..., -alpha_(n-1)]: z^n v = -sum_j alpha_j z^j v.
        comp[-n_in:] = -alpha.reshape(n, n_in, n_in).transpose(1, 0, 2).reshape(n_in, nm)
        if n_in == 1:  # one input: every participation vector is the scalar 1
            z = np.linalg.eigvals(comp)
            out.append((z, np.ones((1, z.size), dtype=complex)))
        else:
            z, v = np.linalg.eig(comp)
            out.append((z, v[:n_in]))
    return out


def lscf_stabilization(frequency_hz: object, frf: object, orders: object,
                       sample_time: float, *, weights: object = None,
                       frequency_tolerance: float = 0.01, damping_tolerance: float = 0.05,
                       mac_min: float = 0.95, max_damping: float = 0.2,
                       min_share: float = 0.5) -> Stabilization:
    """Stabilization diagram and modes of an FRF by poly-reference LSCF.

    Parameters
    ----------
    frequency_hz, frf, orders, sample_time, weights
        As :func:`lscf_poles`; ``orders`` are polynomial orders (``n * inputs`` poles).
    frequency_tolerance, damping_tolerance, mac_min, max_damping, min_share
        As :func:`gbpipe.sysid.stabilization_diagram`; the MAC compares participation
        vectors (used with several inputs).

    Returns
    -------
    Stabilization
        ``method = "lscf"``; ``order`` is a polynomial order; mode shapes are the
        participation vectors over the inputs.
    """
    check_criteria(frequency_tolerance, damping_tolerance, mac_min, max_damping, min_share)
    orders = check_orders(orders)
    dt = check_dt(sample_time)
    poles = [continuous_poles(z, v, dt, max_damping)
             for z, v in lscf_poles(frequency_hz, frf, orders, dt, weights)]
    return stabilize(orders, poles, "lscf", frequency_tolerance=frequency_tolerance,
                     damping_tolerance=damping_tolerance, mac_min=mac_min,
                     min_share=min_share)


def _checked(frequency_hz: object, frf: object, weights: object, sample_time: float
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Validated ``f`` (F,), ``H`` (F, l, m), weights (F, l) and ``dt``."""
    dt = check_dt(sample_time)
    f = np.asarray(frequency_hz, dtype=float)
    h = np.asarray(frf)
    if h.ndim == 1:
        h = h[:, None, None]
    if f.ndim != 1 or h.ndim != 3 or h.shape[0] != f.size:
        raise DataError("frf", f"must have shape (frequency, outputs, inputs) with "
                        f"{f.size} frequencies (frequency_hz shape {f.shape}); got {h.shape}")
    h = h.astype(complex)
    for name, arr in (("frequency_hz", f), ("frf", h)):
        bad = np.flatnonzero(~np.isfinite(arr.reshape(arr.shape[0], -1)).all(axis=1))
        if bad.size:
            raise DataError(name, f"non-finite value at frequency line {bad[0]}; drop or "
                            "repair that line")
    nyquist = 0.5 / dt
    if np.any(np.diff(f) <= 0) or f[0] < 0 or f[-1] > nyquist * (1 + 1e-12):
        raise DataError("frequency_hz", f"must increase strictly within [0, {nyquist:g}] Hz "
                        f"(Nyquist of sample_time {dt:g} s); got {f[0]:g} to {f[-1]:g} Hz")
    if weights is None:
        rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=(0, 2)))
        if np.any(rms == 0):
            raise DataError("frf", f"output {int(np.argmin(rms))} is zero at every line")
        w = np.broadcast_to(1.0 / rms, h.shape[:2])
    else:
        w = np.asarray(weights, dtype=float)
        if w.ndim == 1:
            w = w[:, None]
        if w.shape[0] != f.size or w.shape[1] not in (1, h.shape[1]):
            raise DataError("weights", f"must have shape ({f.size},) or ({f.size}, "
                            f"{h.shape[1]}), got {np.shape(weights)}")
        if not np.all(np.isfinite(w)) or np.any(w < 0):
            raise DataError("weights", "must be finite and >= 0")
        w = np.broadcast_to(w, h.shape[:2])
    return f, h, np.asarray(w), dt
