"""Independent reference for the DaISy tests: least-squares ARX models, numpy only.

Shares no code with :mod:`gbpipe.sysid` or :mod:`gbpipe.lti`: the regression is
``numpy.linalg.lstsq`` on lagged samples and the simulation is the explicit difference
equation. ARX (``A(q) y = B(q) u + e``) is the classical prediction-error estimate (Ljung,
*System Identification*, 2nd ed., 1999, sec. 4.2 and 7.3); as its order grows its FRF
converges to the system's, so a high-order ARX FRF is an independent FRF estimate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Arx", "fit_arx", "arx_protocol", "fit_percent"]


@dataclass(frozen=True)
class Arx:
    """``y[t] = sum_i a[:, i-1] y[t-i] + sum_j b[:, j] u[t-j]`` (``i = 1..na``, ``j = 0..nb-1``).

    Attributes
    ----------
    a : ndarray, shape (l, na, l)
    b : ndarray, shape (l, nb, m)
    """

    a: np.ndarray
    b: np.ndarray

    def simulate(self, u: np.ndarray) -> np.ndarray:
        """Output of the difference equation from rest, shape (N, l)."""
        n = u.shape[0]
        na, nb = self.a.shape[1], self.b.shape[1]
        y = np.zeros((n, self.a.shape[0]))
        with np.errstate(all="ignore"):  # an unstable ARX overflows: its fit is then -inf/nan
            for t in range(n):
                acc = sum(self.b[:, j] @ u[t - j] for j in range(min(nb, t + 1)))
                acc = acc + sum(self.a[:, i - 1] @ y[t - i] for i in range(1, min(na, t) + 1))
                y[t] = acc
        return y

    def frf(self, f: np.ndarray) -> np.ndarray:
        """``A(z)^-1 B(z)`` at ``z = exp(2j pi f)`` (f in cycles per sample), (n_f, l, m)."""
        out = []
        for zi in np.exp(-2j * np.pi * np.asarray(f)):
            a = np.eye(self.a.shape[0]) - sum(
                self.a[:, i] * zi ** (i + 1) for i in range(self.a.shape[1]))
            b = sum(self.b[:, j] * zi**j for j in range(self.b.shape[1]))
            out.append(np.linalg.solve(a, b))
        return np.array(out)


def fit_arx(u: np.ndarray, y: np.ndarray, na: int, nb: int) -> Arx:
    """Least-squares ARX fit on (N, m) inputs and (N, l) outputs."""
    n = u.shape[0]
    k = max(na, nb - 1)
    phi = np.hstack([y[k - i: n - i] for i in range(1, na + 1)]
                    + [u[k - j: n - j] for j in range(nb)])
    theta, *_ = np.linalg.lstsq(phi, y[k:], rcond=None)
    l_, m = y.shape[1], u.shape[1]
    a = theta[: na * l_].T.reshape(l_, na, l_)
    b = theta[na * l_:].T.reshape(l_, nb, m)
    return Arx(a, b)


def fit_percent(y: np.ndarray, y_sim: np.ndarray) -> np.ndarray:
    """``100 (1 - ||y - y_sim|| / ||y - mean y||)`` per output (written out again here)."""
    return 100.0 * (1.0 - np.linalg.norm(y - y_sim, axis=0)
                    / np.linalg.norm(y - y.mean(axis=0), axis=0))


def arx_protocol(u: np.ndarray, y: np.ndarray, orders=range(1, 13)) -> tuple[int, np.ndarray]:
    """The DaISy protocol of ``daisy_protocol.run_protocol`` applied to ARX(n, n + 1).

    Same split (60/20/20 %), same offsets (estimation-segment means), same order rule
    (smallest order within 0.5 points of the best mean selection fit). The model is
    simulated from rest over the whole record, so the estimation segment absorbs the
    initial transient before the selection and test segments are scored.

    Returns
    -------
    order : int
    test_fit : ndarray, shape (l,)
    """
    n = u.shape[0]
    a, b = int(0.6 * n), int(0.8 * n)
    u = u - u[:a].mean(axis=0)
    y = y - y[:a].mean(axis=0)
    sel, test = {}, {}
    for order in orders:
        y_sim = fit_arx(u[:a], y[:a], order, order + 1).simulate(u)
        with np.errstate(all="ignore"):
            s = float(np.mean(fit_percent(y[a:b], y_sim[a:b])))
        if np.isfinite(s):
            sel[order] = s
            test[order] = fit_percent(y[b:], y_sim[b:])
    best = max(sel.values())
    order = min(k for k, v in sel.items() if v >= best - 0.5)
    return order, test[order]
