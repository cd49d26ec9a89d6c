"""What FRF data can and cannot determine about the physical parameters.

Everything here works on the Jacobian ``J`` of the weighted residuals
(log-magnitude [Np] and phase [rad], each divided by its standard deviation) with respect
to the log-parameters ``θ = ln(p / p_prior)``:

* Fisher information ``F = JᵀJ / s²`` (``s`` the noise scale: 1 when the data carry their
  standard deviations, else the residual rms with a floor), covariance ``F⁻¹``, the 95 %
  interval ``p·exp(±1.96 σ_θ)`` and the correlation matrix;
* the SVD ``J = U S Vᵀ``: a right singular vector whose singular value is below
  ``rtol·s_max`` (no effect on the data at all) or whose standard deviation ``s / s_k``
  exceeds ``max_sd`` (the data cannot tell it from noise) is a direction the data do not
  determine. Its entries name the parameters involved: ``v = (1, 1)/√2`` over
  ``(ln J, ln k)`` leaves ``k/J`` unchanged, so "`J` and `k` only as their ratio".

See docs/fit.md for how to read the result.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.stats import norm

from gbpipe.fit.parameters import FreeParameters
from gbpipe.model.frf import Pairing

__all__ = ["Identifiability", "log_jacobian", "analyse", "describe_direction",
           "design_outputs", "Z95", "JACOBIAN_STEP"]

#: Two-sided 95 % quantile of the standard normal distribution.
Z95 = float(norm.ppf(0.975))
#: Central-difference step in θ: the truncation error (~step²) and the round-off
#: (~1e-15/step) of the log-response both stay near 1e-10.
JACOBIAN_STEP = 1e-5


@dataclass
class Identifiability:
    """The local identifiability of the free parameters at one point.

    Attributes
    ----------
    names : list of str
        Key paths of the parameters.
    singular_values : ndarray
        Singular values of the weighted Jacobian (descending).
    directions : ndarray, shape (n, n)
        Right singular vectors as columns, in ``θ`` (log-parameters).
    noise_scale : float
        The residual standard deviation ``s`` the Fisher information assumes [1].
    fisher : ndarray, shape (n, n)
        ``JᵀJ / s²`` [1 per θ²].
    covariance : ndarray, shape (n, n)
        Pseudo-inverse of ``fisher`` over the determined directions [θ²].
    determined : ndarray of bool
        Per direction: the data fix it.
    flagged : ndarray of bool
        Per parameter: takes part in an undetermined direction.
    combinations : list of str
        One sentence per undetermined direction.
    """

    names: list[str]
    singular_values: np.ndarray
    directions: np.ndarray
    noise_scale: float
    fisher: np.ndarray
    covariance: np.ndarray
    determined: np.ndarray
    flagged: np.ndarray
    combinations: list[str]

    @property
    def rank(self) -> int:
        """Number of determined directions."""
        return int(self.determined.sum())

    @property
    def sd(self) -> np.ndarray:
        """Standard deviation of each ``θ`` (inf for flagged parameters)."""
        out = np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))
        out[self.flagged] = np.inf
        return out

    @property
    def correlation(self) -> np.ndarray:
        """Correlation matrix of ``θ`` (NaN rows and columns for flagged parameters)."""
        sd = self.sd
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = self.covariance / np.outer(sd, sd)
        corr[self.flagged] = np.nan
        corr[:, self.flagged] = np.nan
        return corr


def log_jacobian(response: Callable[[np.ndarray], np.ndarray], theta: np.ndarray,
                 step: float = JACOBIAN_STEP) -> np.ndarray:
    """Jacobian of ``[ln|G|, ∠G]`` with respect to ``θ`` by central differences.

    Parameters
    ----------
    response : callable
        ``θ`` -> complex FRF values (a flat vector).
    theta : ndarray
        Log-parameters.
    step : float
        Difference step in ``θ``.

    Returns
    -------
    ndarray, shape (2·m, n)
        Rows: the log-magnitudes [Np] of the m values, then their phases [rad].
        ``ln(G₊/G₋)`` is taken as one complex logarithm, so phase wrapping never
        enters a difference.
    """
    theta = np.asarray(theta, dtype=float)
    cols = []
    for i in range(theta.size):
        e = np.zeros_like(theta)
        e[i] = step
        d = np.log(response(theta + e) / response(theta - e)) / (2 * step)
        cols.append(np.concatenate([d.real, d.imag]))
    return np.column_stack(cols)


def describe_direction(v: np.ndarray, names: Sequence[str], involvement: float = 0.1) -> str:
    """One sentence for an undetermined direction ``v`` in log-parameters.

    Parameters
    ----------
    v : ndarray
        Unit vector in ``θ``.
    names : sequence of str
        Parameter key paths.
    involvement : float
        Entries with ``|v_i|`` below this are not named.
    """
    idx = [i for i in np.argsort(-np.abs(v)) if abs(v[i]) >= involvement]
    q = [f"`{names[i]}`" for i in idx]
    if len(idx) == 1:
        return f"{q[0]} has no visible effect on the data: it keeps its prior value"
    if len(idx) == 2:
        a, b = v[idx[0]], v[idx[1]]
        # θ_a − (a/b)·θ_b is constant along v: the data see a·b^(∓|a/b|)
        x = abs(a / b)
        kind = "ratio" if a * b > 0 else "product"
        plain = bool(np.isclose(x, 1.0, rtol=0.15))
        seen = f"{q[0]}{'/' if a * b > 0 else '·'}{q[1]}" + ("" if plain else f"^{x:.2g}")
        if plain:
            return f"{q[0]} and {q[1]} only as their {kind} ({seen})"
        return f"{q[0]} and {q[1]} only as one {kind}-like combination ({seen})"
    terms = " : ".join(f"{v[i]:+.2f}" for i in idx)
    return (f"{', '.join(q)} only in combination: changing their logarithms in the "
            f"proportions {terms} leaves the data unchanged")


def analyse(jac: np.ndarray, names: Sequence[str], noise_scale: float = 1.0,
            rtol: float = 1e-6, max_sd: float = 0.2, involvement: float = 0.1
            ) -> Identifiability:
    """Identifiability of the parameters from the weighted Jacobian at the optimum.

    Parameters
    ----------
    jac : ndarray, shape (m, n)
        Jacobian of the weighted residuals with respect to ``θ``.
    names : sequence of str
        Parameter key paths (n).
    noise_scale : float, default 1
        Standard deviation of a weighted residual (1 when the data's own standard
        deviations weight the residuals).
    rtol : float, default 1e-6
        A singular value below ``rtol·s_max`` is a direction with no effect at all.
    max_sd : float, default 0.2
        A direction whose standard deviation in ``θ`` exceeds this (a 95 % interval wider
        than a factor exp(±0.39) ≈ 0.68…1.48) is not determined.
    involvement : float, default 0.1
        A parameter takes part in a direction when ``|v_i|`` reaches this.

    Returns
    -------
    Identifiability
    """
    _, s, vt = np.linalg.svd(np.asarray(jac, dtype=float), full_matrices=False)
    v = vt.T
    smax = s[0] if s.size and s[0] > 0 else 1.0
    with np.errstate(divide="ignore"):
        determined = (s > rtol * smax) & (noise_scale / s <= max_sd)
    flagged = np.any(np.abs(v[:, ~determined]) >= involvement, axis=1)
    fisher = (jac.T @ jac) / noise_scale**2
    inv_s2 = np.where(determined, noise_scale**2 / np.where(determined, s, 1.0) ** 2, 0.0)
    covariance = (v * inv_s2) @ v.T
    combos = [describe_direction(v[:, k], names, involvement)
              for k in np.nonzero(~determined)[0][::-1]]
    return Identifiability(list(names), s, v, float(noise_scale), fisher, covariance,
                           determined, flagged, combos)


def design_outputs(cfg: Mapping[str, Any], free: Sequence[str],
                   pairings: Sequence[Pairing], candidates: Sequence[Pairing],
                   f_hz: Any, sigma: float = 0.05, base: np.ndarray | None = None,
                   **kwargs: Any) -> list[dict[str, Any]]:
    """Which added output (sensor or excitation) would make the free parameters identifiable.

    Parameters
    ----------
    cfg : mapping
        Validated configuration at which to linearise (e.g. the fitted one).
    free : sequence of str
        Key paths of the free parameters.
    pairings : sequence of Pairing
        What is measured today.
    candidates : sequence of Pairing
        Each a possible addition (e.g. ``Pairing("Tdrv_to_Tmeter", ("motor_torque_driver",),
        ("torque_meter_driving",))``).
    f_hz : array_like
        Frequency grid [Hz] of every pairing.
    sigma : float, default 0.05
        Standard deviation of the log-magnitude [Np] and phase [rad] of each FRF value.
    base : ndarray, shape (m, n), optional
        The present data's Jacobian, already divided by its noise (any ``R`` with ``RᵀR``
        its Fisher information, e.g. a fit's): used instead of ``pairings`` on ``f_hz``,
        so the first row is what the fit itself determined.
    **kwargs
        ``rtol``, ``max_sd``, ``involvement`` of :func:`analyse`.

    Returns
    -------
    list of dict
        First the present data (``added: None``), then one entry per candidate:
        ``added`` (name), ``rank`` (determined directions of n), ``identifiable`` (key
        paths that are not flagged), ``combinations`` (what stays undetermined).
    """
    free_p = FreeParameters.from_config(cfg, free)
    f = np.asarray(f_hz, dtype=float)
    theta0 = np.zeros(len(free_p.paths))
    if base is None:
        base = log_jacobian(free_p.response(list(pairings), [f] * len(pairings)),
                            theta0) / sigma
    rows = []
    for extra in [None, *candidates]:
        jac = base if extra is None else np.vstack(
            [base, log_jacobian(free_p.response([extra], [f]), theta0) / sigma])
        ident = analyse(jac, free_p.paths, **kwargs)
        rows.append({"added": None if extra is None else extra.name, "rank": ident.rank,
                     "identifiable": [p for p, fl in zip(free_p.paths, ident.flagged,
                                                         strict=True) if not fl],
                     "combinations": ident.combinations})
    return rows
