"""Natural frequencies and damping ratios of the oscillatory modes of a state matrix."""

from __future__ import annotations

import numpy as np

__all__ = ["modes"]


def modes(A: np.ndarray, dt: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies and damping ratios of the oscillatory modes of ``A``.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        State matrix.
    dt : float, optional
        None: continuous time, eigenvalues are poles ``s``. Sample interval [s]: discrete
        time, eigenvalues ``z`` are mapped to ``s = log(z) / dt``.

    Returns
    -------
    freq_hz : ndarray
        Undamped natural frequencies |s|/2π [Hz], ascending, one per conjugate pair.
    zeta : ndarray
        Damping ratios −Re s/|s| [-] (negative for an unstable mode).

    Notes
    -----
    Real poles are not modes. Poles within ``1e-6 max(1, max|s|)`` of the origin are
    dropped: a free-free chain has a double eigenvalue at 0 that rounding splits into a
    tiny complex pair.
    """
    ev = np.linalg.eigvals(np.asarray(A, dtype=float)).astype(complex)
    if dt is not None:
        ev = np.log(np.where(np.abs(ev) < 1e-300, 1e-300, ev)) / dt
    scale = max(1.0, float(np.abs(ev).max(initial=0.0)))
    ev = ev[(ev.imag > 1e-9 * scale) & (np.abs(ev) > 1e-6 * scale)]
    wn = np.abs(ev)
    order = np.argsort(wn)
    return wn[order] / (2 * np.pi), -ev.real[order] / wn[order]
