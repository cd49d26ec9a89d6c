"""The free parameters of a physical fit: key paths, prior values, bounds, log scale.

A fit works on ``θ = ln(p / p_prior)`` for each freed config number ``p`` (a stiffness,
inertia, damping ratio or controller gain): positivity holds by construction, and one step
in ``θ`` is the same relative change for an inertia of 5 kg·m² and a stiffness of
1e8 N·m/rad, so the least-squares problem is well scaled. See docs/fit.md.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from gbpipe.errors import ConfigError
from gbpipe.fit.keypath import get_value, with_values
from gbpipe.model.frf import Pairing, pairing_frf

__all__ = ["FreeParameters", "DEFAULT_FACTOR"]

#: Default search range: prior / 3 … prior · 3.
DEFAULT_FACTOR = 3.0


@dataclass
class FreeParameters:
    """Freed config numbers around a prior configuration.

    Attributes
    ----------
    cfg : mapping
        The validated prior configuration (the fit's start).
    paths : list of str
        Key paths of the free numbers, e.g. ``"gearbox.stiffness[1]"``.
    prior : ndarray
        Their values in ``cfg`` (units of each key, see config/README.md).
    lower, upper : ndarray
        Bounds in the same units.
    """

    cfg: Mapping[str, Any]
    paths: list[str]
    prior: np.ndarray
    lower: np.ndarray
    upper: np.ndarray

    @classmethod
    def from_config(cls, cfg: Mapping[str, Any], paths: Sequence[str],
                    bounds: Mapping[str, tuple[float, float]] | None = None,
                    factor: float = DEFAULT_FACTOR) -> FreeParameters:
        """Read the priors and set the bounds.

        Parameters
        ----------
        cfg : mapping
            Validated configuration.
        paths : sequence of str
            Key paths of the free numbers (each once).
        bounds : mapping, optional
            Key path -> (lower, upper) in the key's unit; the others get
            ``prior / factor … prior · factor``.
        factor : float, default 3
            Default bound factor (> 1).

        Raises
        ------
        ConfigError
            A path that does not name a number, a repeated path, a prior ≤ 0 (no log
            scale), bounds that do not enclose the prior, or ``factor`` ≤ 1.
        """
        paths = list(paths)
        if len(set(paths)) != len(paths) or not paths:
            raise ConfigError("fit.free", f"{paths}: name each free parameter once, at least one")
        if not factor > 1.0:
            raise ConfigError("fit.factor", f"{factor} must be > 1 (bounds prior/f … prior·f)")
        prior = np.array([get_value(cfg, p) for p in paths])
        lower, upper = prior / factor, prior * factor
        for i, path in enumerate(paths):
            if prior[i] <= 0:
                raise ConfigError(path, f"prior {prior[i]} must be > 0: the fit works on "
                                        "log-parameters; start it from a small positive value")
            if bounds and path in bounds:
                lower[i], upper[i] = (float(b) for b in bounds[path])
                if not 0 < lower[i] < prior[i] < upper[i]:
                    raise ConfigError(path, f"bounds {bounds[path]} must satisfy "
                                            f"0 < lower < prior ({prior[i]}) < upper")
        return cls(cfg, paths, prior, lower, upper)

    @property
    def log_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of ``θ = ln(p / p_prior)``."""
        return np.log(self.lower / self.prior), np.log(self.upper / self.prior)

    def values(self, theta: np.ndarray) -> np.ndarray:
        """Parameter values at ``θ`` (units of each key)."""
        return self.prior * np.exp(np.asarray(theta, dtype=float))

    def config(self, theta: np.ndarray) -> dict[str, Any]:
        """The configuration with the free numbers at ``θ`` (a copy)."""
        return with_values(self.cfg, dict(zip(self.paths, self.values(theta), strict=True)))

    def response(self, pairings: Sequence[Pairing], f_hz: Sequence[np.ndarray]
                 ) -> Callable[[np.ndarray], np.ndarray]:
        """``θ`` -> the pairings' FRFs, flattened and concatenated (complex).

        Parameters
        ----------
        pairings : sequence of Pairing
        f_hz : sequence of ndarray
            One frequency grid [Hz] per pairing. The plant is solved once on their
            union (:func:`gbpipe.model.frf.pairing_frf`).
        """
        grids = [np.asarray(f, dtype=float).ravel() for f in f_hz]
        f_all, inverse = np.unique(np.concatenate(grids), return_inverse=True)
        cuts = np.cumsum([0] + [g.size for g in grids])

        def evaluate(theta: np.ndarray) -> np.ndarray:
            g = pairing_frf(self.config(theta), pairings, f_all)
            return np.concatenate([gk[inverse[cuts[k]:cuts[k + 1]]].ravel()
                                   for k, gk in enumerate(g)])
        return evaluate
