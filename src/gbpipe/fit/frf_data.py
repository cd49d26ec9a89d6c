"""FRF data to fit: one pairing's complex FRF on its grid, with its uncertainty.

The fit's residuals are the log-magnitude [Np] and the wrapped phase [rad] of
``G_model / G_data``. For an estimate ``Ĝ = G·(1 + ε)`` with a small relative error ε
both are ≈ the real and imaginary part of ε, so one standard deviation ``sigma`` per
value weights both. :func:`sigma_from_coherence` and :func:`sigma_from_bounds` turn the
usual uncertainty statements into it.

A Welch estimate is not the FRF at its bin but the FRF seen through the window's spectral
kernel: with an excitation whose spectrum is flat over the kernel, ``E[Ĝ](f) = ∫ K(ν)
G(f − ν) dν`` with ``K = |W|²`` normalised. Near a lightly damped mode that is a bias
(resolution bias, Bendat & Piersol §9.1) far beyond the estimate's scatter: on the shaft
line of benchmarks/fit_chain.py (1 s Hann segments, modes of about 1 Hz half-power
bandwidth) 0.04–0.3 Np at 29–35 Hz against a scatter of 0.01–0.09 Np.
``FrfData.segment`` names the estimate's Hann segment length, and the fit then compares
the data with the model's expected estimate (:func:`welch_kernel`) instead of the model
itself. The estimate is a ratio of smoothed spectra, ``K⊛(G·P) / K⊛P`` with ``P`` the
input's spectrum, which a closed loop shapes (the motor torque dips where the chain
resonates): ``FrfData.excitation`` names the motor whose command carried the excitation,
and the fit computes ``P`` from that motor's loop. See docs/fit.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.stats import norm

from gbpipe.errors import DataError
from gbpipe.model.frf import Pairing

__all__ = ["FrfData", "sigma_from_coherence", "sigma_from_bounds", "welch_kernel",
           "ESTIMATORS", "KERNEL_REACH"]

#: Welch FRF estimators :class:`FrfData` knows: through the excitation, and H1.
ESTIMATORS = ("reference", "h1")
#: Reach of the window-kernel rule in Welch resolutions: ν ∈ [−3/T, 3/T].
KERNEL_REACH = 3


@dataclass
class FrfData:
    """One pairing's FRF to fit.

    Attributes
    ----------
    pairing : Pairing
        Its inputs and outputs (bench signal names).
    f_hz : ndarray, shape (n_freq,)
        Frequencies [Hz], positive.
    frf : ndarray, complex, shape (n_freq, n_outputs, n_inputs)
        Output units per input unit (rad/s per N·m for the default pairings). NaN marks a
        value that is left out.
    sigma : ndarray or None
        Standard deviation of the log-magnitude [Np] and of the phase [rad] of each value,
        broadcastable to ``frf``. None: unknown, the fit estimates one common scale from
        its residuals.
    segment : float or None
        Length [s] of the Hann segments of the Welch estimate the FRF is (its resolution
        ``1/segment`` Hz): the fit compares it with the model seen through the same
        window (:func:`welch_kernel`). None: the values are the FRF itself (exact data,
        an identified model's FRF).
    excitation : str or None
        With ``segment``: the motor whose command carried the record's excitation. A
        Welch FRF is a ratio of window-smoothed spectra, ``K⊛(G·P) / K⊛P`` with ``P``
        the input's spectrum, and the motor's own loop shapes ``P`` (it dips where the
        chain resonates); the fit then computes ``P`` from the model's loop. The pairing
        must have that motor's torque as its one input. None: the input's spectrum is
        taken as flat over the kernel (``K⊛G``).
    estimator : str
        ``"reference"`` (``S_yr/S_ur``, through the excitation: ``P = T_ur``, the loop's
        transfer from the excitation to the motor torque) or ``"h1"`` (``S_yu/S_uu``:
        ``P = |T_ur|²``); used with ``excitation``.
    """

    pairing: Pairing
    f_hz: np.ndarray
    frf: np.ndarray
    sigma: np.ndarray | None = None
    segment: float | None = None
    excitation: str | None = None
    estimator: str = "reference"

    def __post_init__(self) -> None:
        src = f"FRF of pairing {self.pairing.name}"
        self.f_hz = np.asarray(self.f_hz, dtype=float).ravel()
        self.frf = np.asarray(self.frf, dtype=complex)
        shape = (self.f_hz.size, len(self.pairing.outputs), len(self.pairing.inputs))
        if self.frf.shape != shape:
            raise DataError(src, f"shape {self.frf.shape}, expected (frequency, output, "
                                 f"input) = {shape}")
        if not np.all(np.isfinite(self.f_hz) & (self.f_hz > 0)):
            raise DataError(src, "frequencies must be finite and > 0 Hz",
                            int(np.argmin(np.isfinite(self.f_hz) & (self.f_hz > 0))))
        if np.any(self.frf[np.isfinite(self.frf)] == 0):
            raise DataError(src, "a zero FRF value has no logarithm: mark it NaN to leave "
                                 "it out")
        if self.sigma is not None:
            self.sigma = np.broadcast_to(np.asarray(self.sigma, dtype=float), shape)
            ok = np.isfinite(self.sigma) & (self.sigma > 0)
            if not np.all(ok | ~np.isfinite(self.frf)):
                raise DataError(src, "sigma must be finite and > 0 wherever the FRF is "
                                     "given (NaN the FRF value to leave it out)")
        if self.segment is not None:
            if not (np.isfinite(self.segment) and self.segment > 0):
                raise DataError(src, f"segment {self.segment} s must be a positive length")
            # the kernel's outer nodes sit 3/segment below: they must stay above DC, where
            # a speed output's FRF is infinite
            low = self.mask.any(axis=(1, 2)) & (self.f_hz <= KERNEL_REACH / self.segment)
            if low.any():
                raise DataError(src, f"{self.f_hz[low][0]:g} Hz is within the window "
                                     f"kernel's reach ({KERNEL_REACH:g}/segment = "
                                     f"{KERNEL_REACH / self.segment:g} Hz) of 0 Hz: "
                                     "NaN the FRF there to leave it out",
                                int(np.argmax(low)))
        if self.estimator not in ESTIMATORS:
            raise DataError(src, f"estimator {self.estimator!r} is not one of {ESTIMATORS}")
        if self.excitation is not None and self.segment is None:
            raise DataError(src, f"excitation {self.excitation!r} weights a Welch estimate's "
                                 "window kernel: give the estimate's segment")
        if self.excitation is not None and len(self.pairing.inputs) != 1:
            raise DataError(src, f"excitation {self.excitation!r} needs a pairing with one "
                                 f"input, that motor's torque; inputs {self.pairing.inputs}")

    @property
    def mask(self) -> np.ndarray:
        """Values that enter the fit (finite)."""
        return np.isfinite(self.frf)

    @property
    def weight(self) -> np.ndarray:
        """``1 / sigma`` of the fitted values (flat; ones when sigma is unknown)."""
        if self.sigma is None:
            return np.ones(int(self.mask.sum()))
        return 1.0 / self.sigma[self.mask]


def welch_kernel(segment: float, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes [Hz] and weights [1] of the expected Welch estimate through a Hann window.

    ``E[Ĝ](f) = ∫ K(ν) G(f − ν) dν`` with ``K(ν) ∝ (sinc(νT) / (1 − (νT)²))²`` the power
    kernel of a Hann window of length ``T``, by the trapezoid rule on ``ν ∈ [−3/T, 3/T]``
    (:data:`KERNEL_REACH`; the tail beyond holds 6e-5 of the kernel, the weights are
    renormalised) with
    ``steps`` nodes per resolution ``1/T``. On a function analytic in a strip the
    trapezoid rule converges as ``exp(−2π d / h)``: here ``d`` is the narrowest mode's
    half-power half-bandwidth ``γ = ζ f_n`` (its pole's distance from the real axis) and
    ``K`` grows as ``exp(2π γ T)`` off the axis, so about ``1 + ln(1/ε) / (2π γ T)`` steps
    reach a relative error ε at that mode's peak (8 steps: 2.4e-5 Np from the ±3/T
    integral at 0.8 % damping, 29 Hz, 1 s; the truncation adds 2.5e-4 Np).
    :class:`gbpipe.fit.residuals.FrfResiduals` doubles ``steps`` until the model's
    expected estimate no longer moves against the data's scatter. A three-node rule
    matching the kernel's moments 1, ``1/(3T²)``, ``1/(3T⁴)`` is off by 0.6 Np there.

    Parameters
    ----------
    segment : float
        Hann segment length ``T`` [s].
    steps : int
        Nodes per ``1/T`` (≥ 1).

    Returns
    -------
    nodes, weights : ndarray, shape (6 steps + 1,)
        Frequency offsets ``ν`` [Hz] (multiples of ``1/(steps·T)``) and weights summing
        to 1.
    """
    if int(steps) < 1:
        raise ValueError(f"steps {steps}: at least one node per resolution")
    t = float(segment)
    x = np.arange(-KERNEL_REACH * steps, KERNEL_REACH * steps + 1) / steps
    k = np.full(x.size, 0.25)           # the limit at νT = ±1, where both factors vanish
    regular = ~np.isclose(np.abs(x), 1.0)
    k[regular] = (np.sinc(x[regular]) / (1.0 - x[regular] ** 2)) ** 2
    return x / t, k / k.sum()


def sigma_from_coherence(coherence: Any, n_averages: int) -> np.ndarray:
    """Standard deviation of ln|Ĝ| and ∠Ĝ [Np, rad] of an H1 estimate from its coherence.

    The normalised random error of an averaged FRF estimate,
    ``ε = √(1 − γ²) / (|γ| √(2 n_d))`` (Bendat & Piersol, *Random Data*, 4th ed.,
    eq. 9.52), is the standard deviation of both the log-magnitude and the phase.

    Parameters
    ----------
    coherence : array_like
        Ordinary coherence γ² [1], in (0, 1].
    n_averages : int
        Number of averaged segments n_d.

    Raises
    ------
    DataError
        Coherence outside (0, 1] or ``n_averages`` < 1.
    """
    g2 = np.asarray(coherence, dtype=float)
    if n_averages < 1 or not np.all((g2 > 0) & (g2 <= 1)):
        raise DataError("coherence", "must lie in (0, 1] with at least one average")
    # a coherence of exactly 1 would give infinite weight: floor at double round-off
    return np.maximum(np.sqrt((1.0 - g2) / (2.0 * n_averages * g2)), 1e-12)


def sigma_from_bounds(lower: Any, upper: Any, level: float = 0.95) -> np.ndarray:
    """Standard deviation of ln|Ĝ| [Np] from a confidence band of the magnitude.

    Parameters
    ----------
    lower, upper : array_like
        Lower and upper bound of ``|G|`` (same unit) at confidence ``level``, taken as
        symmetric on a log scale.
    level : float, default 0.95
        Two-sided confidence level of the band, in (0, 1).

    Raises
    ------
    DataError
        Bounds not ``0 < lower ≤ upper``, or a level outside (0, 1).
    """
    lo, hi = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    if not 0 < level < 1:
        raise DataError("bounds", f"confidence level {level} must lie in (0, 1)")
    if not np.all((lo > 0) & (hi >= lo)):
        raise DataError("bounds", "need 0 < lower <= upper")
    return np.maximum(np.log(hi / lo) / (2.0 * norm.ppf(0.5 + level / 2)), 1e-12)
