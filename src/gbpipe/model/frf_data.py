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
itself. See docs/fit.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.stats import norm

from gbpipe.errors import DataError
from gbpipe.model.frf import Pairing

__all__ = ["FrfData", "sigma_from_coherence", "sigma_from_bounds", "welch_kernel"]


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
    """

    pairing: Pairing
    f_hz: np.ndarray
    frf: np.ndarray
    sigma: np.ndarray | None = None
    segment: float | None = None

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
            # the kernel's outer nodes sit 1/segment below: they must stay above DC, where
            # a speed output's FRF is infinite
            low = self.mask.any(axis=(1, 2)) & (self.f_hz <= 1.0 / self.segment)
            if low.any():
                raise DataError(src, f"{self.f_hz[low][0]:g} Hz is within one resolution "
                                     f"(1/segment = {1.0 / self.segment:g} Hz) of 0 Hz: "
                                     "NaN the FRF there to leave it out",
                                int(np.argmax(low)))

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


def welch_kernel(segment: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes [Hz] and weights [1] of the expected Welch estimate through a Hann window.

    The power kernel ``K(ν) = |W(ν)|²`` of a Hann window of length ``T`` (normalised to
    unit area) has the moments ``m₂ = ∫ν²K = 1/(3T²)`` and ``m₄ = ∫ν⁴K = 1/(3T⁴)``
    (``m_2k = ∫|w⁽ᵏ⁾(t)|² dt / ((2π)^2k ∫w² dt)``). The symmetric three-node rule
    ``(0, ±h)`` with weights ``(1 − 2a, a, a)`` matching them, ``h = √(m₄/m₂) = 1/T`` and
    ``a = m₂²/(2m₄) = 1/6``, integrates ``∫K(ν) G(f − ν) dν`` exactly for every
    polynomial of degree ≤ 5 in ``ν``: ``E[Ĝ](f) ≈ ⅔ G(f) + ⅙ (G(f − 1/T) + G(f + 1/T))``.

    Parameters
    ----------
    segment : float
        Hann segment length ``T`` [s].

    Returns
    -------
    nodes, weights : ndarray, shape (3,)
        Frequency offsets ``(0, −1/T, 1/T)`` [Hz] and ``(2/3, 1/6, 1/6)``.
    """
    h = 1.0 / float(segment)
    return np.array([0.0, -h, h]), np.array([4.0, 1.0, 1.0]) / 6.0


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
