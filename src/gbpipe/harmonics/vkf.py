"""Vold-Kalman order tracking filter, second generation: several orders at once.

Each order ``o`` of a family is a complex envelope ``c(t)`` on the phasor of the tracked
shaft, ``x_o(t) = 2 Re(c(t) exp(1j o theta(t)))``, with ``theta`` the shaft angle from
the tachometer (:mod:`gbpipe.harmonics.angle`). The envelope is the least-squares
solution of the *data equation* ``y = x_o + noise`` and the *structural equation*
``nabla^s c = small`` (its s-th difference), weighted by ``w``:

    (I + D_s^T W D_s) c = exp(-1j o theta) y                                       (1)

a real, symmetric, positive definite band matrix of half bandwidth ``s`` and a complex
right-hand side, solved by banded Cholesky (:func:`scipy.linalg.cholesky_banded`) with
memory linear in the record. Far from the record ends it is the zero-phase filter
``H(f) = 1 / (1 + w |2 sin(pi f / fs)|^(2 s))`` of the envelope, so the weight giving a
half-power (-3 dB) bandwidth ``B`` [Hz] is ``w = (sqrt(2) - 1) / (2 sin(pi B / fs))^(2s)``
(Vold and Leuridan 1993; Tuma 2005). The bandwidth may be fixed in Hz or in orders (then
``B(t) = B_orders * f_shaft(t)``, one weight per difference row).

Several orders: the second-generation filter solves all envelopes jointly. Here the joint
least-squares problem is solved by block Gauss-Seidel over the orders (backfitting): the
envelope of order ``k`` is (1) on the signal minus every other order's current
waveform, in turn, until a pass changes the residual by less than ``tol`` of the
harmonics found. The residual settles in a few passes; orders closer than about the
bandwidth keep trading a shared component (the joint problem itself can hardly tell them
apart), which changes their split more than their sum, so the passes stop on the residual.
Orders within about a bandwidth of each other (or of 0 Hz) can make the passes diverge
(an order's update is symmetric but its gain exceeds 1 near the record's ends): a run
whose change is twice its least, two or more passes after it, returns the least's output
(:mod:`gbpipe.harmonics.least_change`) and names the crowded orders.
The tolerance bounds what is left unconverged over the whole record, and a bin where
orders crowd leaves more: with ``tol = 1e-3`` (-60 dB overall) the worst rpm bin of the
motor and mesh-1 families read 59.7-62 dB on the 18 rpm/s crossing sweeps
(``benchmarks/removal.py --crossings``), 65-71 dB at ``1e-4`` (the default: -80 dB
overall, 1.4 times the passes' CPU) and 70-75 dB at ``1e-5`` (3 times). Against the
joint solution of one sparse solve (tests/harmonics/test_vkf.py): orders three
bandwidths apart reach it within -91 dB at ``1e-4``, 1.5 bandwidths apart within -64 dB;
orders inside one bandwidth never settle (each pass still moves the residual by about
1e-3). A run that ends at ``max_iter`` before the tolerance logs a warning with the
change it reached.

Numerics. The condition number of (1) is about ``1 + 4^s w``; above ~1e14 a float64
Cholesky loses the digits a -60 dB removal needs, so narrower bandwidths are refused
(decimate the record first, or use :mod:`gbpipe.harmonics.regression`). Below it the
rounding error lies in the fast envelope directions that the structural equation damps
(iterative refinement: < 5 dB at > 90 dB on the test sweeps, at twice the cost).

Pieces. A record longer than :data:`PIECE` and two margins is removed in overlapping
pieces (:func:`gbpipe.harmonics.pieces.by_pieces`): the memory is that of a piece
instead of the record's (~12 GB at 60 min at 5 kHz), and every order's phasors stay
cached (:data:`PHASOR_CACHE_BYTES`; recomputed, they cost almost a solve). A piece solves
(1) truncated at its ends; a cut changes the solution near it as ``rho^m`` after ``m``
samples, ``rho`` the modulus of the filter's slowest pole, the root of
``1 + w (2 - z - 1/z)^s`` nearest the unit circle (:func:`envelope_margin`). The margin
is where that falls to ``tol``, below what the passes leave unconverged anyway, plus two
revolutions: 8300 samples (1.7 s) at 1 Hz, 5 kHz, ``s = 2`` (``rho = 1 - 1.1e-3``), 1 %
more work on pieces of 2^21 samples. Most of the work is one complex banded solve
(``zpbtrs``) per order and pass (docs/removal.md, "Hour-long records").
"""

from __future__ import annotations

import logging
from typing import Literal

import numpy as np
from scipy.linalg import cho_solve_banded, cholesky_banded
from scipy.special import comb

from gbpipe.harmonics.checks import as_count, as_positive, as_signal
from gbpipe.harmonics.least_change import LeastChange
from gbpipe.harmonics.pieces import by_pieces, slowest_revolution
from gbpipe.harmonics.removal_inputs import Families, removal_inputs
from gbpipe.harmonics.tacho import AngleMethod
from gbpipe.harmonics.vkf_report import Passes, crowded_orders, passes_warning
from gbpipe.progress import Progress

__all__ = ["PIECE", "structural_weight", "envelope_margin", "EnvelopeFilter", "residual_vkf"]

log = logging.getLogger(__name__)

#: Largest condition number of (1) accepted (see the module notes).
MAX_CONDITION = 1e14

#: Bytes of order phasors (cosine and sine) kept between backfitting passes: a pass over
#: an order whose phasors are not kept recomputes them, 24 ns per sample against its
#: banded solve's 30 and the rest of its update's 10 (numpy's cos and sin). 512 MB keeps
#: every order of a test record, of the 1.2 M sample sweep and of a 6-min bench record
#: (13 orders; 128 MB kept 4 there, and 1 at 20 min: 40 % more work), and 15 orders of a
#: :data:`PIECE`.
PHASOR_CACHE_BYTES = 512 * 2**20

#: Samples kept from one piece of a long record (7 min at 5 kHz; module notes,
#: "Pieces"): every record of the default and CI runs is removed whole, as before. A
#: piece holds about 60 arrays of its length for 13 orders (the orders' waveforms, their
#: phasors, the factor and its complex copy, the work arrays): 1 GB.
PIECE = 1 << 21


def structural_weight(bandwidth: np.ndarray | float, fs: float,
                      filter_order: int) -> np.ndarray:
    """Weight ``w`` of the structural equation for a half-power envelope bandwidth.

    Parameters
    ----------
    bandwidth : float or array_like
        Half-power (-3 dB) bandwidth of the envelope low-pass [Hz], i.e. the half width
        of the band-pass around each order.
    fs : float
        Sample rate [Hz].
    filter_order : int
        Order ``s`` of the difference in the structural equation (1: first generation
        smoothing of the envelope's slope, 2: of its curvature, ...).

    Returns
    -------
    numpy.ndarray
        ``(sqrt(2) - 1) / (2 sin(pi B / fs))^(2 s)`` [-].
    """
    s = 2.0 * np.sin(np.pi * np.asarray(bandwidth, dtype=float) / fs)
    return (np.sqrt(2.0) - 1.0) / s ** (2 * filter_order)


class EnvelopeFilter:
    """The banded system (1) of one record, factorised once for every order.

    Parameters
    ----------
    weight : numpy.ndarray, shape (n - s,)
        Structural weight of each difference row [-].
    n : int
        Samples.
    filter_order : int
        Difference order ``s``.

    Raises
    ------
    ValueError
        The system is too ill-conditioned for float64 (bandwidth too narrow).
    """

    def __init__(self, weight: np.ndarray, n: int, filter_order: int) -> None:
        s = filter_order
        self.d = np.array([(-1.0) ** (s - j) * comb(s, j) for j in range(s + 1)])
        self.w = np.broadcast_to(np.asarray(weight, dtype=float), (n - s,))
        self.s = s
        condition = 1.0 + 4.0**s * float(self.w.max())
        if condition > MAX_CONDITION:
            raise ValueError(
                f"bandwidth too narrow for the sample rate: the envelope system's condition "
                f"number ~{condition:.1e} exceeds {MAX_CONDITION:.0e}; widen the bandwidth, "
                f"lower filter_order, decimate the record, or use the regression method")
        ab = np.zeros((s + 1, n))
        ab[0] = 1.0
        for k in range(s + 1):  # lower band k of D^T W D
            for j in range(s + 1 - k):
                ab[k, j:j + n - s] += self.w * (self.d[j] * self.d[j + k])
        self.factor = cholesky_banded(ab, lower=True)
        # The same factor as complex numbers, for the envelopes: LAPACK's banded solve runs
        # its triangular sweeps once per right-hand side column, and one complex column
        # (zpbtrs) takes 1.7x less time than the real and imaginary parts as two real
        # columns (dpbtrs). Its result differs by rounding only (~1e-12 of the envelope).
        self._factor_complex = self.factor.astype(complex)

    def solve(self, b: np.ndarray, *, overwrite: bool = False) -> np.ndarray:
        """Solve (1) for real or complex columns ``b`` (n, m); ``overwrite``: ``b`` may be
        solved in place (it is, when Fortran-ordered)."""
        factor = self._factor_complex if np.iscomplexobj(b) else self.factor
        return cho_solve_banded((factor, True), b, overwrite_b=overwrite, check_finite=False)


def envelope_margin(weight: float, filter_order: int, decay: float) -> int:
    """Samples over which a change of (1) at a cut fades to ``decay`` of its size.

    Away from the record ends the envelope is the response of the zero-phase filter whose
    poles are the roots of ``1 + w (2 - z - 1/z)^s``; the one nearest the unit circle,
    ``|z| = rho < 1``, sets how far a cut (a piece's end, where the system is truncated)
    reaches into the solution: as ``rho^m`` after ``m`` samples.

    Parameters
    ----------
    weight : float
        The largest structural weight ``w`` of the record [-] (narrowest bandwidth).
    filter_order : int
        Difference order ``s``.
    decay : float
        Share of the cut's change left at the margin's end [-], 0 < decay < 1.

    Returns
    -------
    int
        ``ceil(log(decay) / log(rho))`` samples.
    """
    s = filter_order
    # (2 - z - 1/z)^s = -1/w: s values u of 2 - z - 1/z, each giving a reciprocal
    # pair of poles, z^2 - (2 - u) z + 1 = 0; in u, not as one polynomial in z, whose
    # coefficients ~w would bury the poles' distance from 1 (~w^(-1/2s)) in rounding
    u = weight ** (-1.0 / s) * np.exp(1j * np.pi * (2 * np.arange(s) + 1) / s)
    root = np.sqrt(u * (u - 4.0))
    rho = float(np.minimum(np.abs(2.0 - u + root), np.abs(2.0 - u - root)).max()) / 2.0
    return int(np.ceil(np.log(decay) / np.log(rho)))


def residual_vkf(x: np.ndarray, fs: float, pulse_times: np.ndarray, families: Families,
                 pulses_per_rev: int = 1, *, bandwidth: float = 1.0,
                 bandwidth_unit: Literal["Hz", "order"] = "Hz", filter_order: int = 2,
                 max_iter: int = 20, tol: float = 1e-4, t0: float = 0.0,
                 method: AngleMethod = "pchip", piece: int = PIECE) -> np.ndarray:
    """Remove order families with a second-generation Vold-Kalman filter.

    Parameters
    ----------
    fs : float
        Sample rate [Hz].
    x, fs, pulse_times, families, pulses_per_rev, t0, method
        The common signature (:func:`gbpipe.harmonics.removal.remove_harmonics`).
        All orders of all families are tracked jointly.
    bandwidth : float
        Half-power bandwidth of each order's envelope: in Hz, or in orders of the shaft
        (then it follows the speed).
    bandwidth_unit : {"Hz", "order"}
        Unit of ``bandwidth``.
    filter_order : int
        Difference order of the structural equation, 1 to 4 (2: envelope response falls
        as ``f^-4`` beyond the bandwidth).
    max_iter : int
        Passes over the orders at most (joint solution by backfitting).
    tol : float
        Stop when a pass changes the residual by less than ``tol`` times the norm of the
        harmonics found (1e-4: the residual has settled to -80 dB of them overall; see
        the module notes for what a bin keeps).
    piece : int
        Samples per piece of a long record (:func:`gbpipe.harmonics.pieces.by_pieces`;
        module notes, "Pieces").

    Returns
    -------
    numpy.ndarray
        The residual: ``x`` minus every tracked order's waveform (unit of ``x``).

    Raises
    ------
    DataError
        ``x`` is not one channel of finite samples.
    ValueError
        Bad bandwidth or unit, or a bandwidth too narrow for float64 at this ``fs``.
    """
    x = as_signal(x, "x")  # every sample, before the pieces' long work
    bandwidth = as_positive(bandwidth, "bandwidth", bandwidth_unit)
    if bandwidth_unit not in ("Hz", "order"):
        raise ValueError(f"bandwidth_unit must be 'Hz' or 'order'; got {bandwidth_unit!r}")
    s = as_count(filter_order, "filter_order")
    if s > 4:
        raise ValueError(f"filter_order must be 1 to 4; got {s}")
    max_iter = as_count(max_iter, "max_iter")
    tol = as_positive(tol, "tol", "relative units")
    pulse_times = np.asarray(pulse_times, dtype=float)
    rev = slowest_revolution(pulse_times, pulses_per_rev)  # s
    # the slowest pole: the narrowest bandwidth in Hz (in orders: at the slowest speed)
    narrowest = bandwidth if bandwidth_unit == "Hz" or rev == 0 else bandwidth / rev
    # a cut's change fades below the tolerance the passes stop at; two revolutions more
    # keep every kept sample between the same pulses as in the whole record (the angle's
    # pchip slopes use one pulse either side)
    margin = (envelope_margin(float(structural_weight(narrowest, fs, s)), s, min(tol, 0.5))
              + int(np.ceil(2 * rev * fs)))

    # said before the long work: where the passes may diverge (see _backfit)
    pairs = crowded_orders(families, 1.0 / rev, narrowest) if rev > 0 else []
    crowd = "; ".join(pairs[:6]) + (f"; {len(pairs) - 6} more" if len(pairs) > 6 else "")
    if crowd:  # a note, not a warning: their sum is removed while the passes converge
        log.info("Vold-Kalman orders within 2 x %.3g Hz (the bandwidth) of each other at "
                 "the slowest speed (%.3g Hz): %s; the backfitting may not separate "
                 "them", narrowest, 1.0 / rev, crowd)

    outcomes: list[Passes | None] = []  # per piece: one warning for them all

    def one(part: np.ndarray, pulses: np.ndarray, start: float) -> np.ndarray:
        out, passes = _backfit(part, fs, pulses, families, pulses_per_rev, bandwidth,
                               bandwidth_unit, s, max_iter, tol, start, method)
        outcomes.append(passes)
        return out
    out = by_pieces(x, fs, pulse_times, margin, one, piece, t0)
    if (warning := passes_warning(outcomes, tol, max_iter, crowd)) is not None:
        log.warning(warning)
    return out


def _backfit(x: np.ndarray, fs: float, pulse_times: np.ndarray, families: Families,
             pulses_per_rev: int, bandwidth: float, bandwidth_unit: str, s: int,
             max_iter: int, tol: float, t0: float, method: AngleMethod,
             ) -> tuple[np.ndarray, Passes | None]:
    """:func:`residual_vkf` of one piece (checked arguments), and how its passes ended
    short of ``tol`` (None: they reached it)."""
    rec, _, orders = removal_inputs(x, fs, pulse_times, families, pulses_per_rev, t0, method)
    y = rec.x[rec.span]
    n = y.size
    if bandwidth_unit == "Hz":
        w = structural_weight(bandwidth, rec.fs, s)
    else:  # one weight per difference row, from the shaft speed at the row's centre
        rate = rec.shaft_rate()
        w = structural_weight(bandwidth * 0.5 * (rate[:n - s] + rate[s:]), rec.fs, s)
    filt = EnvelopeFilter(w, n, s)

    # Order 0 (k = 0) is the slowly varying mean, tracked with the orders so that a large
    # mean or trend (a torque record's load) does not leak into the low orders, but kept.
    orders = np.concatenate([[0.0], orders])
    r = y.copy()
    waves = np.zeros((orders.size, n))
    # Work arrays, filled in place (a pass over one order touches the record ~15 times):
    # the target, the new waveform, the phase, its cosine and sine, and the demodulated
    # target as one complex column that the banded solver overwrites.
    target, new, buf, cos_work, sin_work = (np.empty(n) for _ in range(5))
    rhs = np.empty((n, 1), dtype=complex)
    progress = Progress(log, f"Vold-Kalman backfitting of {orders.size} envelopes over "
                        f"{n} samples", max_iter)
    # the phasors of the first orders, kept between passes (PHASOR_CACHE_BYTES)
    kept = min(orders.size - 1, PHASOR_CACHE_BYTES // (16 * n))
    phasors: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    # the output of the least-changing pass after the first (whose change is the whole
    # estimate's), returned if the passes diverge or end above it (docs/removal.md, "Vold-
    # Kalman orders within a bandwidth"); a converging run's change can rise a while
    guard, least = LeastChange(patience=2, factor=2.0), np.empty(n)
    for done in range(1, max_iter + 1):
        before = r.copy()
        for k, o in enumerate(orders):
            np.add(r, waves[k], out=target)
            if k == 0:
                new[:] = filt.solve(target[:, None])[:, 0]
            else:
                cos, sin = phasors.get(k, (cos_work, sin_work))
                if k not in phasors:  # first pass, or beyond the kept orders
                    if k <= kept:
                        cos, sin = phasors[k] = np.empty(n), np.empty(n)
                    np.multiply(o, rec.theta, out=buf)
                    np.cos(buf, out=cos)
                    np.sin(buf, out=sin)
                # envelope c of target * exp(-1j ph), solved as conj(c) from
                # target * exp(1j ph): the system is real, so conjugating the right-hand
                # side conjugates the solution exactly
                np.multiply(target, cos, out=rhs.real[:, 0])
                np.multiply(target, sin, out=rhs.imag[:, 0])
                c_conj = filt.solve(rhs, overwrite=True)[:, 0]
                # 2 Re(c exp(1j ph)) = 2 (Re c cos - Im c sin)
                np.multiply(c_conj.real, cos, out=new)
                np.multiply(c_conj.imag, sin, out=buf)
                new += buf
                new *= 2.0
            np.subtract(new, waves[k], out=buf)
            r -= buf
            waves[k] = new
        # Judge the residual, not the orders: close orders trade a shared component back
        # and forth (their split is barely determined) while their sum, hence the
        # residual, has converged. Relative to the harmonics found, not to x: a torque's
        # large mean would make a tolerance on ||x|| meaningless.
        found = float(np.linalg.norm(y - r - waves[0]))
        change = float(np.linalg.norm(r - before)) / max(found, np.finfo(float).tiny)
        if change <= tol:
            break
        if done > 1 and guard.update(change, done):
            np.add(r, waves[0], out=least)
        elif guard.diverged(change, done):
            break
        progress(done, f"residual change {change:.2g}")
    # diverged, or ended above its least: the least's output, else the last pass's
    worse = change > tol and change > guard.least
    out = rec.x.copy()
    out[rec.span] = least if worse else r + waves[0]
    return out, (None if change <= tol else
                 Passes(done < max_iter, guard.least, guard.at, change, done, worse))
