"""Weighted residuals of a physical fit to FRFs, and their correlation along frequency.

For every FRF value the residual is ``ln(G_model / G_data)``: its real part the
log-magnitude error [Np], its imaginary part the wrapped phase error [rad], each divided
by the value's standard deviation (:class:`gbpipe.model.frf_data.FrfData`). For a Welch
estimate (``FrfData.segment`` given) the model is its expected estimate, the model on the
window kernel's nodes weighted (:func:`gbpipe.model.frf_data.welch_kernel`). The unknowns
are ``θ = ln(p / p_prior)`` (:class:`gbpipe.model.parameters.FreeParameters`), plus an
optional input-to-output delay in ms.

A residual set (this one, or the modal table's of :mod:`gbpipe.model.fit_modes`) offers
what :func:`gbpipe.model.fit.fit_parameters` and the goodness-of-fit test
(:mod:`gbpipe.model.goodness`) use: ``residual(θ)``, ``jacobian(θ)``, ``sequences``
(residuals that follow each other along frequency share a label), ``groups`` (the
pairing or mode each residual belongs to), ``frequency`` [Hz] of each residual,
``has_sigma`` and ``n_evaluations``. See docs/fit.md.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gbpipe.model.frf_data import FrfData, welch_kernel
from gbpipe.model.identifiability import log_jacobian
from gbpipe.model.parameters import FreeParameters

__all__ = ["FrfResiduals", "correlation_factor", "DELAY_UNIT"]

#: s: one step in θ of the delay (θ's delay unit is 1 ms).
DELAY_UNIT = 1e-3


class FrfResiduals:
    """Weighted log-residuals of the model FRFs against the data.

    Parameters
    ----------
    free : FreeParameters
        The free numbers and their prior.
    data : sequence of FrfData
        One FRF per pairing (grids may differ).
    delay : bool
        Add one unknown: an input-to-output delay [ms] applied to every model FRF.
    """

    def __init__(self, free: FreeParameters, data: Sequence[FrfData], delay: bool) -> None:
        self.free = free
        self.n = len(free.paths)
        # a Welch estimate is compared with the model's expected estimate: the model on the
        # window kernel's nodes around each frequency, weighted (FrfData.segment)
        kernels = [welch_kernel(d.segment) if d.segment is not None
                   else (np.zeros(1), np.ones(1)) for d in data]
        self.response = free.response([d.pairing for d in data],
                                      [(d.f_hz[None, :] + nodes[:, None]).ravel()
                                       for d, (nodes, _) in zip(data, kernels, strict=True)])
        self.mask = np.concatenate([d.mask.ravel() for d in data])
        # each fitted value as a weighted sum over the flat response: its position per
        # kernel node (the response of a pairing is node-major), weight 0 pads a node
        width = max(w.size for _, w in kernels)
        where, weights, first = [], [], 0
        for d, (_, w) in zip(data, kernels, strict=True):
            pos = first + np.arange(d.frf.size)[:, None] + d.frf.size * np.arange(width)
            where.append(np.where(np.arange(width) < w.size, pos, 0))
            weights.append(np.broadcast_to(np.pad(w, (0, width - w.size)), pos.shape))
            first += d.frf.size * w.size
        self.where = np.concatenate(where)[self.mask]
        self.node_weights = np.concatenate(weights)[self.mask]
        f_all = np.concatenate([np.broadcast_to(d.f_hz[:, None, None], d.frf.shape).ravel()
                                for d in data])[self.mask]
        # angular frequency of every fitted value, in rad per ms (θ's delay unit)
        self.delay_phase = f_all * 2 * np.pi * DELAY_UNIT if delay else None
        # one label per FRF element (pairing, output, input): the residuals of one element
        # along frequency form a sequence whose correlation the intervals account for
        labels, pairs, first = [], [], 0
        for k, d in enumerate(data):
            elements = np.arange(d.frf[0].size).reshape(d.frf.shape[1:])
            labels.append(np.broadcast_to(elements, d.frf.shape).ravel() + first)
            pairs.append(np.full(d.frf.size, k))
            first += d.frf[0].size
        element = np.concatenate(labels)[self.mask]
        self.sequences = np.concatenate([element, element + first])     # real, then imag
        names = np.array([d.pairing.name for d in data])
        self.groups = np.tile(names[np.concatenate(pairs)[self.mask]], 2)
        self.frequency = np.tile(f_all, 2)
        self.target = np.concatenate([d.frf.ravel() for d in data])[self.mask]
        w = np.concatenate([d.weight for d in data])
        self.weight = np.concatenate([w, w])
        self.has_sigma = data[0].sigma is not None
        self.n_evaluations = 0

    @property
    def size(self) -> int:
        """Number of residuals."""
        return int(self.weight.size)

    def values(self, theta: np.ndarray) -> np.ndarray:
        """Model FRF values (complex, the fitted ones, flat) at ``θ``."""
        self.n_evaluations += 1
        flat = self.response(theta[:self.n])
        if self.where.shape[1] == 1:        # no Welch kernel: the values themselves
            g = flat[self.where[:, 0]]
        else:
            g = np.einsum("ij,ij->i", flat[self.where], self.node_weights)
        if self.delay_phase is None:
            return g
        # the delay at the value's own frequency, not per kernel node: over ±1/T its
        # phase changes by 2π·τ/T (6e-4 rad for 0.1 ms and 1 s segments)
        return g * np.exp(-1j * self.delay_phase * theta[self.n])

    def residual(self, theta: np.ndarray) -> np.ndarray:
        """Weighted residuals at ``θ``: log-magnitudes [Np], then phases [rad], over sigma."""
        r = np.log(self.values(theta) / self.target)    # Np + j·rad, phase wrapped
        return self.weight * np.concatenate([r.real, r.imag])

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`residual` with respect to ``θ`` (central differences)."""
        return self.weight[:, None] * log_jacobian(self.values, theta)


def correlation_factor(residual: np.ndarray, sequences: np.ndarray) -> float:
    """Variance inflation of a mean of residuals that are correlated along frequency.

    A model error is smooth in frequency, so neighbouring residuals are not independent
    and ``JᵀJ/s²`` overstates the information. The factor ``1 + 2 Σ ρ_k`` (the ratio of
    the long-run to the plain variance) uses the autocorrelation ``ρ_k`` at lag ``k``
    pooled over the sequences (one per FRF element and real/imaginary part, in frequency
    order) and summed up to the first lag at which it is no longer positive (Geyer's
    initial positive sequence).

    Parameters
    ----------
    residual : ndarray
        Weighted residuals.
    sequences : ndarray of int
        Sequence label of each residual (its members in frequency order).

    Returns
    -------
    float
        At least 1.
    """
    r = residual - residual.mean()
    groups = [r[sequences == g] for g in np.unique(sequences)]
    c0 = sum(float(g @ g) for g in groups)
    if c0 <= 0:
        return 1.0
    total = 0.0
    for k in range(1, max(g.size for g in groups)):
        rho = sum(float(g[:-k] @ g[k:]) for g in groups if g.size > k) / c0
        if rho <= 0:
            break
        total += rho
    return 1.0 + 2.0 * total
