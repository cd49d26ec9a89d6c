"""Weighted residuals of a physical fit to FRFs, and their correlation along frequency.

For every FRF value the residual is ``ln(G_model / G_data)``: its real part the
log-magnitude error [Np], its imaginary part the wrapped phase error [rad], each divided
by the value's standard deviation (:class:`gbpipe.fit.frf_data.FrfData`). For a Welch
estimate (``FrfData.segment`` given) the model is its expected estimate, the model on the
window kernel's nodes weighted (:func:`gbpipe.fit.frf_data.welch_kernel`, fine enough
that the prior model's expected estimate has settled against the data's scatter) and,
when the record's excitation is named (``FrfData.excitation``), weighted too by the
input's spectrum that the excited motor's loop shapes: ``K⊛(G·P) / K⊛P``. The unknowns
are ``θ = ln(p / p_prior)`` (:class:`gbpipe.fit.parameters.FreeParameters`), plus an
optional input-to-output delay in ms.

A residual set (this one, or the modal table's of :mod:`gbpipe.fit.modes`) offers
what :func:`gbpipe.fit.estimate.fit_parameters` and the goodness-of-fit test
(:mod:`gbpipe.fit.goodness`) use: ``residual(θ)``, ``jacobian(θ)``, ``sequences``
(residuals that follow each other along frequency share a label), ``groups`` (the
pairing or mode each residual belongs to), ``frequency`` [Hz] of each residual,
``has_sigma`` and ``n_evaluations``. See docs/fit.md.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

import numpy as np

from gbpipe.errors import ConfigError, DataError
from gbpipe.fit.frf_data import FrfData, welch_kernel
from gbpipe.fit.identifiability import log_jacobian
from gbpipe.fit.parameters import FreeParameters
from gbpipe.model.assembly import bench_chain
from gbpipe.model.chain import Motor
from gbpipe.model.frf import Pairing
from gbpipe.model.stability import controller_path

__all__ = ["FrfResiduals", "correlation_factor", "DELAY_UNIT", "MAX_KERNEL_STEPS"]

log = logging.getLogger(__name__)

#: s: one step in θ of the delay (θ's delay unit is 1 ms).
DELAY_UNIT = 1e-3
#: Finest window-kernel rule: nodes per Welch resolution (a mode of 0.01·resolution).
MAX_KERNEL_STEPS = 128


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
    steps : sequence of array_like of int, optional
        One entry per data item: window-kernel nodes per resolution
        (:func:`gbpipe.fit.frf_data.welch_kernel`) at each of its frequencies (ignored
        without a Welch segment). Default: 2, doubled at the frequencies where the prior
        model's expected estimate still moves by more than a tenth of the data's sigma
        (1e-3 without sigma) between ``m`` and ``2m`` nodes, at most
        :data:`MAX_KERNEL_STEPS`: fine nodes only near a mode narrower than the rule.
        :meth:`refined` refines them at another ``θ`` (the fit's optimum: its modes
        may have moved off the prior's).
    """

    def __init__(self, free: FreeParameters, data: Sequence[FrfData], delay: bool,
                 steps: Sequence[Any] | None = None) -> None:
        self.free = free
        self.n = len(free.paths)
        self.data = list(data)
        self.delay = delay
        motors = {m.name: m for m in bench_chain(free.cfg).motors}
        if steps is None:
            steps = [_kernel_steps(free, d, np.zeros(self.n)) for d in data]
        self.steps = [np.broadcast_to(np.asarray(m, dtype=int), d.f_hz.shape)
                      for d, m in zip(data, steps, strict=True)]
        # a Welch estimate is compared with the model's expected estimate: the model on the
        # window kernel's nodes around each frequency, weighted (FrfData.segment), by the
        # input's spectrum too where the excited motor's loop shapes it (the loop's own
        # sensor response is evaluated on the same nodes: a pairing of its own)
        kernels = [_kernels(d, m) for d, m in zip(data, self.steps, strict=True)]
        loops = [_excited_motor(free, d, motors) for d in data]
        grids = [_grid(d, ks) for d, ks in zip(data, kernels, strict=True)]
        pairings = [d.pairing for d in data]
        loop_pairings, loop_grids, loop_gains = [], [], []
        for d, m, grid in zip(data, loops, grids, strict=True):
            if m is not None:
                loop_pairings.append(Pairing(f"{d.pairing.name} loop", d.pairing.inputs,
                                             (m.controller.sensor,)))
                loop_grids.append(grid)
                s = 2j * np.pi * grid
                loop_gains.append(m.controller.kp + m.controller.ki / s)
        self.response = free.response(pairings + loop_pairings, grids + loop_grids)
        self.n_values = sum(g.size * d.frf[0].size for d, g in zip(data, grids, strict=True))
        self.loop_gain = np.concatenate(loop_gains) if loop_gains else None
        self.power = np.concatenate([np.full(g.size, d.estimator == "h1") for d, m, g in
                                     zip(data, loops, grids, strict=True) if m is not None]
                                    ) if loop_gains else None
        self.mask = np.concatenate([d.mask.ravel() for d in data])
        # each fitted value as a weighted sum over the flat response: its position per
        # kernel node (a pairing's response runs over its grid, frequency by frequency and
        # node by node, each an (output, input) block), weight 0 pads a node; and its
        # input-spectrum weight per node: a position in the loops' responses (the same
        # grid, one value per node), or the last, a constant 1
        width = max(k[0].size for ks in kernels for k in ks)
        n_loop = 0 if self.loop_gain is None else self.loop_gain.size
        node = np.arange(width)
        where, weights, spectrum, first, first_loop = [], [], [], 0, 0
        for d, ks, m in zip(data, kernels, loops, strict=True):
            count = np.array([k[0].size for k in ks])
            start = np.concatenate([[0], np.cumsum(count)[:-1]])
            table = np.zeros((d.f_hz.size, width))
            for i, k in enumerate(ks):
                table[i, :k[1].size] = k[1]
            elems = d.frf[0].size
            freq, element = np.divmod(np.arange(d.frf.size), elems)
            valid = node < count[freq][:, None]
            grid_pos = start[freq][:, None] + node
            where.append(np.where(valid, first + grid_pos * elems + element[:, None], 0))
            weights.append(table[freq])
            if m is None:
                spectrum.append(np.full(valid.shape, n_loop))
            else:
                spectrum.append(np.where(valid, first_loop + grid_pos, n_loop))
                first_loop += int(count.sum())
            first += int(count.sum()) * elems
        self.where = np.concatenate(where)[self.mask]
        self.node_weights = np.concatenate(weights)[self.mask]
        self.spectrum_where = np.concatenate(spectrum)[self.mask]
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

    def refined(self, theta: np.ndarray) -> FrfResiduals:
        """This residual set with the kernel rule refined at ``θ`` too (per frequency the
        larger of the present steps and those :meth:`__init__` would choose at ``θ``);
        itself when nothing changes."""
        steps = [np.maximum(m, _kernel_steps(self.free, d, theta[:self.n]))
                 for d, m in zip(self.data, self.steps, strict=True)]
        if all(np.array_equal(a, b) for a, b in zip(steps, self.steps, strict=True)):
            return self
        out = FrfResiduals(self.free, self.data, self.delay, steps)
        out.n_evaluations = self.n_evaluations
        return out

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
        elif self.loop_gain is None:        # the input's spectrum flat over the kernel
            g = np.einsum("ij,ij->i", flat[self.where], self.node_weights)
        else:
            # the excitation reaches the motor torque through its loop, T = 1/(1 + K·G_m)
            # (reference estimate: P = T; H1: P = |T|²): E[Ĝ] = K⊛(G·P) / K⊛P
            t = 1.0 / (1.0 + self.loop_gain * flat[self.n_values:])
            p = np.append(np.where(self.power, np.abs(t) ** 2, t), 1.0)[self.spectrum_where]
            w = self.node_weights * p
            g = np.einsum("ij,ij->i", flat[self.where], w) / w.sum(axis=1)
        if self.delay_phase is None:
            return g
        # the delay at the value's own frequency, not per kernel node: over ±3/T its
        # phase changes by 6π·τ/T (2e-3 rad for 0.1 ms and 1 s segments)
        return g * np.exp(-1j * self.delay_phase * theta[self.n])

    def residual(self, theta: np.ndarray) -> np.ndarray:
        """Weighted residuals at ``θ``: log-magnitudes [Np], then phases [rad], over sigma."""
        r = np.log(self.values(theta) / self.target)    # Np + j·rad, phase wrapped
        return self.weight * np.concatenate([r.real, r.imag])

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`residual` with respect to ``θ`` (central differences)."""
        return self.weight[:, None] * log_jacobian(self.values, theta)


def _kernels(data: FrfData, steps: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per frequency of ``data``: the kernel rule's nodes [Hz] and weights (the value
    itself, weight 1, without a Welch segment)."""
    if data.segment is None:
        return [(np.zeros(1), np.ones(1))] * data.f_hz.size
    rules = {int(m): welch_kernel(data.segment, int(m)) for m in np.unique(steps)}
    return [rules[int(m)] for m in steps]


def _grid(data: FrfData, kernels: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """Every frequency [Hz] the model is evaluated at for ``data``: its own, or each with
    its kernel's nodes (rounded to 1e-9 Hz, so that neighbours' shared nodes, equal up
    to the last bit, are one point of the union the plant is solved on)."""
    if data.segment is None:
        return data.f_hz
    return np.round(np.concatenate([f + k[0] for f, k in zip(data.f_hz, kernels,
                                                              strict=True)]), 9)


def _kernel_steps(free: FreeParameters, data: FrfData, theta: np.ndarray) -> np.ndarray:
    """Kernel nodes per resolution at each frequency of ``data``: 2, doubled where the
    model's expected estimate at ``θ`` moves by more than a tenth of the data's sigma
    (1e-3 without sigma) between ``m`` and ``2m`` nodes (once the trapezoid rule
    converges exponentially the move is the coarser rule's error); at most
    :data:`MAX_KERNEL_STEPS`, with a warning where the last doubling still moved the
    value (a mode narrower than the finest rule resolves)."""
    steps = np.full(data.f_hz.size, 1 if data.segment is None else 2)
    if data.segment is None:
        return steps
    freq = (np.arange(data.frf.size) // data.frf[0].size)[data.mask.ravel()]
    tol = 0.1 * data.sigma[data.mask] if data.sigma is not None else 1e-3
    coarse = FrfResiduals(free, [data], False, [steps]).values(theta)
    active = np.ones(steps.size, dtype=bool)
    while active.any():
        trial = np.where(active, 2 * steps, steps)
        fine = FrfResiduals(free, [data], False, [trial]).values(theta)
        moved = np.zeros(steps.size, dtype=bool)
        np.logical_or.at(moved, freq, np.abs(np.log(coarse / fine)) > tol)
        # where the finer rule moved the value, the coarser one was off: keep the finer
        # and test it in turn; elsewhere the coarser one has settled
        steps = np.where(moved, trial, steps)
        coarse = np.where(moved[freq], fine, coarse)
        active = moved
        if active.any() and steps.max() >= MAX_KERNEL_STEPS:
            log.warning("FRF of pairing %s: the window-kernel rule still moved between %d "
                        "and %d nodes per resolution at %s Hz (a mode narrower than the "
                        "finest rule resolves); the fit uses %d", data.pairing.name,
                        MAX_KERNEL_STEPS // 2, MAX_KERNEL_STEPS,
                        np.round(data.f_hz[active], 3).tolist(), MAX_KERNEL_STEPS)
            break
    return steps


def _excited_motor(free: FreeParameters, data: FrfData,
                   motors: dict[str, Motor]) -> Motor | None:
    """The controlled motor whose loop shapes the input's spectrum of ``data`` (None:
    no excitation named, or a motor without a loop)."""
    if data.excitation is None:
        return None
    src = f"FRF of pairing {data.pairing.name}"
    motor = motors.get(data.excitation)
    if motor is None:
        raise DataError(src, f"excitation {data.excitation!r} is not a motor of the chain "
                             f"({', '.join(motors)})")
    if data.pairing.inputs != (motor.input,):
        raise DataError(src, f"excitation {data.excitation!r}: the pairing's input must be "
                             f"that motor's torque {motor.input!r}, not {data.pairing.inputs}")
    if motor.controller.type == "none":
        return None
    # the loop's gains are read from the prior: a free one would move the weight as well
    loop = controller_path(free.cfg, motor)
    for path in free.paths:
        if path.startswith(loop + "."):
            raise ConfigError(path, f"a gain of motor {motor.name!r}, whose loop shapes the "
                                    "excitation of the Welch estimate fitted: free it on "
                                    "data without FrfData.excitation, or hold it")
    return motor


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
