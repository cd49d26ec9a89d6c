"""Basis in time of the slowly varying amplitudes of the harmonic regression.

:class:`AmplitudeBasis`: cubic (or any degree) B-splines on uniform knots, local, so that
the regression's normal equations are banded, or Legendre polynomials over the record
(global, dense); and how far the least-squares fit in the spline basis reaches
(:meth:`AmplitudeBasis.reach`), the margin of a long record's pieces.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import BSpline, make_lsq_spline

__all__ = ["AmplitudeBasis"]


class AmplitudeBasis:
    """Basis in time of the slowly varying harmonic amplitudes.

    Parameters
    ----------
    t_start, t_end : float
        Span of the record [s].
    kind : {"bspline", "legendre"}
        Cubic (or ``degree``) B-splines on uniform knots, or Legendre polynomials.
    knot_spacing : float
        Distance between knots [s] (B-splines only).
    degree : int
        Spline degree, or the highest Legendre degree.

    Attributes
    ----------
    size : int
        Number of basis functions.
    support : int
        Basis functions that can be non-zero at one time (bandwidth of the normal
        equations, in functions).
    breaks : numpy.ndarray
        Times [s] where the set of non-zero functions changes (knots).
    """

    def __init__(self, t_start: float, t_end: float, kind: str, knot_spacing: float,
                 degree: int) -> None:
        if kind not in ("bspline", "legendre"):
            raise ValueError(f"basis must be 'bspline' or 'legendre'; got {kind!r}")
        self.kind, self.degree = kind, degree
        self.t_start, self.t_end = t_start, t_end
        if kind == "bspline":
            n_int = max(1, int(np.ceil((t_end - t_start) / knot_spacing)))
            inner = np.linspace(t_start, t_end, n_int + 1)
            self.knots = np.r_[[t_start] * degree, inner, [t_end] * degree]
            self.size = self.knots.size - degree - 1
            self.support = degree + 1
            self.breaks = inner[1:-1]
        else:
            self.size = self.support = degree + 1
            self.breaks = np.empty(0)

    def values(self, t: np.ndarray) -> tuple[np.ndarray, int]:
        """Values (len(t), support) of the functions non-zero on ``t``, and the index of
        the first; ``t`` must lie within one knot interval (B-splines)."""
        if self.kind == "legendre":
            u = 2.0 * (t - self.t_start) / (self.t_end - self.t_start) - 1.0
            return np.polynomial.legendre.legvander(u, self.degree), 0
        tc = np.clip(t, self.t_start, self.t_end)
        # the interval of the earliest sample: functions first .. first + degree are the
        # non-zero ones on it (at t_end, the last interval's)
        interval = np.searchsorted(self.knots, tc.min(), side="right") - 1
        first = int(np.clip(interval - self.degree, 0, self.size - self.support))
        # those functions alone, by scipy's compiled de Boor with coefficients that select
        # them; BSpline.design_matrix gives the same values but checks its input with
        # Python's min/max over every sample (4 ms for a block of 8192 samples)
        pick = np.zeros((self.size, self.support))
        pick[first + np.arange(self.support), np.arange(self.support)] = 1.0
        return BSpline(self.knots, pick, self.degree, extrapolate=False)(tc), first

    def unfollowed(self, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        """``y`` minus its least-squares fit in the basis: what an amplitude in this basis
        cannot follow of a phase ``y(t)`` (unit of ``y``)."""
        if self.kind == "legendre":
            u = 2.0 * (t - self.t_start) / (self.t_end - self.t_start) - 1.0
            return y - np.polynomial.legendre.legval(
                u, np.polynomial.legendre.legfit(u, y, self.degree))
        # by the banded normal equations: one pass over the samples, where scipy's default
        # QR reduction costs ~1 us per sample (1.4 s on the 1.2 M-sample sweep); the uniform
        # B-splines' Gram matrix is well conditioned, and the fit serves one threshold
        # (second_lines), which rounding at 1e-13 cannot move
        return y - make_lsq_spline(t, y, self.knots, self.degree, method="norm-eq")(t)

    def reach(self, decay: float) -> int:
        """Knot intervals over which the least-squares fit in the B-spline basis forgets a
        change of the data by ``decay`` [-] (0 < decay < 1).

        The inverse of the Gram matrix of B-splines of degree ``p`` on uniform knots
        falls by ``|lambda|`` per knot, ``lambda`` the root inside the unit circle, of
        largest modulus, of the Gram matrix's symbol: the cardinal B-spline of degree
        ``2 p + 1`` at the integers (``lambda = -0.535`` for cubics). An amplitude's
        regressors (the B-splines times the cosine and sine of its order over many
        revolutions per knot) have half that Gram matrix, so a fit's value at one time
        depends on the data ``k`` knots away as ``|lambda|^k``.

        Raises
        ------
        ValueError
            The basis is Legendre (global: every coefficient depends on every sample).
        """
        if self.kind != "bspline":
            raise ValueError("a Legendre basis is global: its fit has no finite reach")
        p = self.degree
        if p == 0:  # disjoint boxes: the fit on one interval sees that interval alone
            return 1
        symbol = BSpline.basis_element(np.arange(2 * p + 3), extrapolate=False)(
            np.arange(1, 2 * p + 2))
        roots = np.roots(symbol)
        lam = float(np.abs(roots[np.abs(roots) < 1]).max())
        return int(np.ceil(np.log(decay) / np.log(lam)))
