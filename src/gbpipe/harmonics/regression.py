"""Angle-domain least-squares harmonic regression with slowly varying amplitudes.

Every order ``o_k`` of every family is fitted jointly as

    x(t) = sum_k sum_j B_j(t) (a_kj cos(o_k theta(t)) + b_kj sin(o_k theta(t))) + e(t)

plus a slowly varying mean ``sum_j B_j(t) m_j`` (fitted, never subtracted: a torque
record's large mean and trends would otherwise leak into the low orders), with ``theta``
the shaft angle of each sample from the tachometer
(:mod:`gbpipe.harmonics.angle`; the regressors are functions of angle, evaluated at the
record's own samples, so nothing is resampled) and ``B_j`` a basis in time for the
slowly varying amplitudes: cubic B-splines on uniform knots (default: local, so the
normal equations are banded) or Legendre polynomials over the record (global, dense).

The normal equations are accumulated block by block (blocks of samples inside one knot
interval: each touches only ``degree + 1`` spline functions), into lower banded storage,
and solved by banded Cholesky: memory linear in the record, independent of its length
for the matrix (the blocks' design: :mod:`gbpipe.harmonics.regression_design`).
Estimating all families at once, unlike a cascade, leaves no family's leakage in
another's estimate; orders closer than about ``1 / (revolutions per knot interval)`` are
told apart only through the joint fit, at the cost of noise gain.

Where an order crosses a structural mode, its line is the excitation times the mode's
FRF along the order's frequency; with ``modes`` the regressors also hold that swept
modal response (:mod:`gbpipe.harmonics.crossings`), with one global coefficient per
order and mode: a dense border of the banded normal equations, eliminated by its Schur
complement. With ``twist`` (a second line-carrying shaft's angle against the
tachometer's, :mod:`gbpipe.harmonics.shaft_angles`) the orders whose phase the twist moves
faster than their envelope follows are fitted on both angles.

Pieces. With B-splines, a record longer than ``piece`` (default 2^22 samples, 14 min at
5 kHz) and two margins is fitted in overlapping pieces (:func:`by_pieces`): its arrays
are held per piece. A spline fit forgets a change of the data by ``|lambda|`` per knot
(:meth:`AmplitudeBasis.reach`; 0.535 for cubics), a modal carrier its start in
``1 / (zeta 2 pi f_n)``: the margin (:func:`regression_margin`) is where both have fallen
to :data:`PIECE_DECAY`. A piece has knots of its own (uniform over it) and, with
``modes``, carrier coefficients of its own (a constant excitation estimated per piece):
it fits the noise near each order with other functions than the whole record: the
residuals differ by that, within twice the noise a fit takes. With ``overwrite_x`` the
residual replaces the record (held once). A Legendre basis is global: fitted whole.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from typing import Literal

import numpy as np
from scipy.linalg import cho_solve_banded, cholesky_banded

from gbpipe.harmonics.amplitude_basis import AmplitudeBasis
from gbpipe.harmonics.checks import as_count, as_positive, as_signal
from gbpipe.harmonics.crossings import as_modes, crossing_pairs
from gbpipe.harmonics.pieces import PIECE, by_pieces, slowest_revolution
from gbpipe.harmonics.regression_design import (
    block_cuts,
    border_design,
    carrier_blocks,
    line_phases,
    local_design,
)
from gbpipe.harmonics.removal_inputs import Families, removal_inputs
from gbpipe.harmonics.shaft_angles import checked_twist, second_lines
from gbpipe.harmonics.tacho import AngleMethod

__all__ = ["AmplitudeBasis", "PIECE_DECAY", "family_groups", "regression_margin",
           "residual_regression"]

#: What a piece's cut leaves of its change on the kept samples [-]: -80 dB, below the
#: -60 dB at which a removal is judged (docs/removal.md)
PIECE_DECAY = 1e-4

#: Tikhonov weight of each modal carrier's coefficient, relative to the carrier's power
BORDER_RIDGE = 1e-6
#: Bytes of modal-carrier columns kept from the accumulation for the subtraction pass
#: (the carriers' exponentials and recursions are about half of a regression's time)
BORDER_CACHE_BYTES = 128 * 2**20


def regression_margin(knot_spacing: float | Mapping[str, float], degree: int,
                      modes: Sequence[Sequence[float]] | None, pulse_times: np.ndarray,
                      pulses_per_rev: int, fs: float) -> int:
    """Samples on each side of a piece of a long record (module notes, "Pieces").

    The spline fit's reach (:meth:`AmplitudeBasis.reach` of :data:`PIECE_DECAY`) at the
    coarsest knot spacing; the modal carriers' memory, ``log(1 / PIECE_DECAY)`` time
    constants ``1 / (zeta 2 pi f_n)`` of the slowest-decaying mode (a piece's carrier
    starts in the steady state, the record's carries the sweep's history); whichever is
    longer, and two revolutions at the slowest speed (the same pulses either side of
    every kept sample).

    Parameters
    ----------
    knot_spacing, degree, modes, pulses_per_rev
        As :func:`residual_regression`.
    pulse_times : ndarray
        Tacho pulse times [s].
    fs : float
        Sample rate [Hz].
    """
    spacings = (list(knot_spacing.values()) if isinstance(knot_spacing, Mapping)
                else [knot_spacing])
    longest = max(as_positive(h, "knot_spacing", "s") for h in spacings)     # s
    reach = longest * AmplitudeBasis(0.0, 1.0, "bspline", 1.0,
                                     as_count(degree, "degree")).reach(PIECE_DECAY)
    if modes is not None and len(modes):
        m = as_modes(modes)
        reach = max(reach, float(np.log(1 / PIECE_DECAY) / (2 * np.pi * m[:, 0] * m[:, 1]).min()))
    rev = slowest_revolution(pulse_times, pulses_per_rev)
    return int(np.ceil((reach + 2 * rev) * fs))


def family_groups(families: Families, spacing: Mapping[str, float]
                  ) -> list[tuple[float, dict]]:
    """Families grouped by their knot spacing [s], finest first.

    Raises
    ------
    ValueError
        A key that is neither a family nor ``default``, a family with no spacing (and no
        ``default``), or a spacing that is not positive.
    """
    unknown = sorted(set(spacing) - set(families) - {"default"})
    if unknown:
        raise ValueError(f"knot_spacing names {unknown}, which are not families "
                         f"({sorted(families)}) nor 'default'")
    groups: dict[float, dict] = {}
    for name, orders in families.items():
        if name not in spacing and "default" not in spacing:
            raise ValueError(f"knot_spacing has no entry for family {name!r} and no "
                             f"'default': add one")
        h = as_positive(spacing.get(name, spacing.get("default")),
                        f"knot_spacing[{name!r}]", "s")
        groups.setdefault(h, {})[name] = orders
    return sorted(groups.items())


def residual_regression(x: np.ndarray, fs: float, pulse_times: np.ndarray,
                        families: Families, pulses_per_rev: int = 1, *,
                        basis: Literal["bspline", "legendre"] = "bspline",
                        knot_spacing: float | Mapping[str, float] = 1.0, degree: int = 3,
                        ridge: float = 1e-10,
                        modes: Sequence[Sequence[float]] | None = None,
                        mode_reach: float = 3.0,
                        modal_families: Collection[str] | None = None,
                        twist: np.ndarray | None = None,
                        twist_families: Collection[str] | None = None,
                        twist_phase: float = 0.1,
                        block: int = 8192, t0: float = 0.0,
                        method: AngleMethod = "pchip", piece: int = PIECE,
                        overwrite_x: bool = False) -> np.ndarray:
    """Remove order families by joint least-squares regression on the shaft angle.

    Parameters
    ----------
    x, fs, pulse_times, families, pulses_per_rev, t0, method
        The common signature (:func:`gbpipe.harmonics.removal.remove_harmonics`).
        All orders of all families are fitted together.
    basis : {"bspline", "legendre"}
        Basis of the amplitudes in time (module notes).
    knot_spacing : float or mapping str -> float
        Knot distance of the B-spline basis [s]: amplitude and phase changes faster than
        about this are not followed (a resonance crossing lasts ``2 zeta f_mode /
        sweep rate`` s). A mapping gives it per family (key: family name, or ``default``
        for the others): families with one spacing are fitted jointly, the groups one after
        the other, finest first. Why per family: each fitted amplitude also takes the
        random part within about ``1 / knot_spacing`` Hz of its order, and low orders,
        whose frequency moves slowly through a resonance, need fewer knots than
        mesh orders -- a coarser basis there removes less of the broadband response.
    degree : int
        Spline degree (bspline), or highest Legendre degree (legendre).
    ridge : float
        Tikhonov term, relative to the mean diagonal of the normal matrix [-]: keeps
        near-coincident orders solvable without changing well-separated ones.
    modes : array_like, shape (modes, 2), optional
        Frequency [Hz] and damping ratio [-] of the structural modes (closed-loop bench
        modes, :func:`gbpipe.harmonics.envelope_modes`). Every order that comes within
        ``mode_reach`` half-power half widths of a mode is also fitted with the mode's
        swept response to it (:func:`gbpipe.harmonics.modal_carriers`), one complex
        coefficient over the record: at a crossing the line rings with the mode on the
        mode's time constant, which a slow envelope cannot follow and fine knots follow
        only by taking the mode's broadband response too (docs/removal.md, "Crossings").
        With a per-family ``knot_spacing`` the groups are fitted one after the other and
        a group's carriers meet the later groups' lines unfitted: give carriers
        (``modal_families``) only to the families of the last group.
    mode_reach : float
        Half-power half widths ``zeta f_n`` within which an order counts as near a mode [-].
    modal_families : collection of str, optional
        The families whose orders get modal carriers (default: all). The carrier's one
        coefficient assumes the family's excitation constant over the record: a family
        whose excitation follows the operating point (the converters' pulsating torque on
        ramp tests with steps) is fitted better by its envelope alone.
    twist : array_like, shape (n,), optional
        Angle of a second line-carrying shaft minus the tachometer shaft's at every sample
        of ``x`` [rad] (:func:`gbpipe.harmonics.shaft_twist` of the two shafts' speeds,
        or the difference of two tachometer angles). The orders of ``twist_families`` are
        then fitted on both angles, each with its own envelope (and modal carriers):
        a line locked to the second shaft changes phase against the tachometer by
        ``order x twist``, which an envelope on the tachometer angle follows only as
        fast as its knots (docs/removal.md, "A second angle per gearbox").
    twist_families : collection of str, optional
        The families whose lines are also locked to the second shaft (default: all of
        them, as on a back-to-back bench where both gearboxes and both motors carry every
        family).
    twist_phase : float
        Of those, an order gets its second line only where the twist moves its phase by
        more than this beyond what its envelope follows, ``order x max|twist - fit of
        twist in the basis|`` [rad]: elsewhere the tachometer angle's envelope takes the
        line to better than ``twist_phase`` of its amplitude (0.1 rad: -20 dB) at the
        twist's fastest change, and a second envelope would only take more of the
        broadband response.
    block : int
        Samples per block of the normal-equation accumulation (memory per block).
    piece : int
        Samples per piece of a long record (B-splines; :func:`regression_margin`).
    overwrite_x : bool
        ``x`` (float64) may hold the residual on return: a record's channels held once.

    Returns
    -------
    numpy.ndarray
        The residual: ``x`` minus the fitted harmonics (unit of ``x``), of the shape of
        ``x``. ``x`` may hold several channels of one record, shape ``(n, channels)``:
        each is fitted as it would be alone, but the regressors and the factor of the
        normal equations are computed once for all. Several records of one angle (a
        record and its harmonic part), shape ``(records, n, channels)``, share them too;
        each record's products are those of a call of its own (the same numbers).

    Raises
    ------
    DataError
        A channel with NaN/inf samples (named ``x[:, j]``), and the errors of the pulses.
    ValueError
        Unknown basis, non-positive knot spacing, ridge or mode reach, or modes that are
        not (frequency > 0, 0 < damping ratio < 1) pairs.
    """
    xa = np.asarray(x, dtype=float)
    axis = 1 if xa.ndim == 3 else 0  # time
    if basis == "bspline" and np.isfinite(xa).all():  # (else the checks below raise)
        margin = regression_margin(knot_spacing, degree, modes, pulse_times,
                                   pulses_per_rev, fs)
        if xa.shape[axis] > max(piece, 4 * margin) + 2 * margin:
            twist = None if twist is None else np.asarray(twist, dtype=float)

            def one(part: np.ndarray, pulses: np.ndarray, start: float) -> np.ndarray:
                lo = int(round((start - t0) * fs))  # of the piece's first sample
                return np.moveaxis(residual_regression(
                    np.moveaxis(part, 0, axis), fs, pulses, families, pulses_per_rev,
                    basis=basis, knot_spacing=knot_spacing, degree=degree, ridge=ridge,
                    modes=modes, mode_reach=mode_reach, modal_families=modal_families,
                    twist=None if twist is None else twist[lo:lo + part.shape[0]],
                    twist_families=twist_families, twist_phase=twist_phase, block=block,
                    t0=start, method=method, piece=part.shape[0]), axis, 0)
            moved = np.moveaxis(xa, axis, 0)
            return np.moveaxis(by_pieces(moved, fs, np.asarray(pulse_times, dtype=float), margin,
                                         one, piece, t0, moved if overwrite_x else None), 0, axis)
    if isinstance(knot_spacing, Mapping):
        out = xa
        for k, (spacing, group) in enumerate(family_groups(families, knot_spacing)):
            out = residual_regression(  # (after the first group, ``out`` is its own)
                out, fs, pulse_times, group, pulses_per_rev, basis=basis, knot_spacing=spacing,
                degree=degree, ridge=ridge, modes=modes, mode_reach=mode_reach,
                modal_families=modal_families, twist=twist, twist_families=twist_families,
                twist_phase=twist_phase, block=block, t0=t0, method=method, piece=piece,
                overwrite_x=overwrite_x or k > 0)
        return out
    if xa.ndim not in (1, 2, 3):
        raise ValueError(f"x must be (n,), (n, channels) or (records, n, channels): {xa.shape}")
    # (records, n, channels): every record's channels share the regressors and the factor
    xs = xa.reshape((1,) * (3 - xa.ndim) + xa.shape) if xa.ndim > 1 else xa[None, :, None]
    if xa.ndim > 1:  # every channel checked; the first one carries the angle map's checks
        for k, j in np.ndindex(xs.shape[0], xs.shape[2]):
            as_signal(xs[k, :, j], f"x[{k}, :, {j}]" if xa.ndim == 3 else f"x[:, {j}]")
    rec, fam, orders = removal_inputs(xs[0, :, 0], fs, pulse_times, families, pulses_per_rev,
                                      t0, method)
    knot_spacing, ridge = (as_positive(knot_spacing, "knot_spacing", "s"),
                           as_positive(ridge, "ridge", "relative units"))
    degree, block = as_count(degree, "degree"), as_count(block, "block", 16)
    times = rec.times
    amp = AmplitudeBasis(float(times[0]), float(times[-1]), basis, knot_spacing, degree)
    y = xs[:, rec.span]
    # the lines: every order on the tachometer angle, and those of the families locked
    # to a second shaft again on its angle (theta + twist); per line its angle's index
    angles = [rec.theta]
    on_second = np.zeros(orders.size, dtype=bool)
    if twist is not None:
        tw = checked_twist(twist, xs.shape[1])[rec.span]
        angles.append(rec.theta + tw)
        # the phase change the envelope cannot follow: fitting such an order on the
        # tachometer angle alone leaves about that share of its line
        on_second = second_lines(fam, twist_families, float(np.abs(amp.unfollowed(
            times, tw)).max()), twist_phase)
    lines = [(0, orders), (1, orders[on_second])] if on_second.any() else [(0, orders)]
    carriers_of: list[tuple[int, np.ndarray, list[tuple[int, int]]]] = []
    m = np.empty((0, 2))
    if modes is not None and len(modes):  # the swept modal response of orders near a mode
        m = as_modes(modes)
        mode_reach = as_positive(mode_reach, "mode_reach", "half-power half widths")
        rate = np.diff(rec.theta) * fs / (2 * np.pi)  # shaft rate [rev/s]
        carried = np.concatenate([np.full(o.size, modal_families is None or name in
                                          modal_families) for name, o in fam.items()])
        for a, ords in lines:
            keep = carried if a == 0 else carried[on_second]
            carriers_of.append((a, ords, [(k, j) for k, j in crossing_pairs(
                ords, (float(rate.min()), float(rate.max())), m, mode_reach) if keep[k]]))
    per_function = 2 * sum(o.size for _, o in lines) + 1
    n_unknown, width = amp.size * per_function, amp.support * per_function  # (of one block)
    ab, rhs = np.zeros((width, n_unknown)), np.zeros((xs.shape[0], n_unknown, xs.shape[2]))
    # the modal carriers' coefficients are global (the mode's residue times the order's
    # excitation, which the carrier's ring-up pins down where it crosses the mode): a
    # dense border of the banded normal matrix
    n_border = 2 * sum(len(p) for _, _, p in carriers_of)
    cross_nb, gram_b = np.zeros((n_unknown, n_border)), np.zeros((n_border, n_border))
    rhs_b = np.zeros((xs.shape[0], n_border, xs.shape[2]))
    cuts = block_cuts(times, amp.breaks, block)
    # the lower triangle of a local normal matrix, entry (i, j) -> lower band storage
    # (i - j, first column + j), in one indexed addition per block
    low_i, low_j = np.tril_indices(width)
    band_row = low_i - low_j
    carriers = carrier_blocks(angles, fs, m, carriers_of, cuts)
    kept = [] if n_border * times.size * 8 <= BORDER_CACHE_BYTES else None
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):  # blocks: memory per block only
        design, c0 = local_design(amp, times[a:b], line_phases(angles, lines, a, b))
        gram = design.T @ design
        ab[band_row, c0 + low_j] += gram[low_i, low_j]
        for r in range(xs.shape[0]):  # each record's products as in a call of its own
            rhs[r, c0:c0 + width] += design.T @ y[r, a:b]
        if n_border:
            border = border_design(next(carriers))
            if kept is not None:
                kept.append(border)
            cross_nb[c0:c0 + width] += design.T @ border
            gram_b += border.T @ border
            for r in range(xs.shape[0]):
                rhs_b[r] += border.T @ y[r, a:b]
    ab[0] += ridge * float(np.mean(ab[0]))
    # finite by construction (checked signals and angles): no input scans
    factor = (cholesky_banded(ab, lower=True, check_finite=False), True)
    coefs = [cho_solve_banded(factor, rhs[r], check_finite=False) for r in range(xs.shape[0])]
    coefs_b = [np.zeros((n_border, xs.shape[2]))] * xs.shape[0]
    if n_border:  # block elimination: the border's Schur complement, then the band
        a_inv_c = cho_solve_banded(factor, cross_nb, check_finite=False)
        schur = gram_b - cross_nb.T @ a_inv_c
        # a carrier far from its mode is almost a slow envelope times the order's phasor,
        # which the band already holds: the Schur complement cancels to rounding there,
        # and a coefficient set by rounding adds power. Its part the band cannot explain
        # is weighted against BORDER_RIDGE of its own power (-60 dB: what a carrier
        # adds below that is no resonance)
        schur[np.diag_indices(n_border)] += BORDER_RIDGE * np.diag(gram_b)
        coefs_b = [np.linalg.solve(schur, rhs_b[r] - cross_nb.T @ coef)
                   for r, coef in enumerate(coefs)]
        for coef, coef_b in zip(coefs, coefs_b, strict=True):
            coef -= a_inv_c @ coef_b
    for coef in coefs:
        coef[::per_function] = 0.0  # the slow mean is fitted, never subtracted
    out = xs if overwrite_x else xs.copy()
    seg = out[:, rec.span]
    borders = iter(kept) if kept is not None else map(  # or again, from the start
        border_design, carrier_blocks(angles, fs, m, carriers_of, cuts))
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        design, c0 = local_design(amp, times[a:b], line_phases(angles, lines, a, b))
        border = next(borders) if n_border else None
        for r, (coef, coef_b) in enumerate(zip(coefs, coefs_b, strict=True)):
            seg[r, a:b] -= design @ coef[c0:c0 + width]
            if border is not None:
                seg[r, a:b] -= border @ coef_b
    return out.reshape(xa.shape)
