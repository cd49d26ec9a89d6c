"""What a Vold-Kalman run tells its user: where its orders crowd, said before the long
work, and how its passes ended, one warning for all the pieces of a record.

An hour-long record is removed in pieces (:func:`gbpipe.harmonics.pieces.by_pieces`),
each backfitted on its own; a warning per piece and signal made 72 lines for the hour's
8 signals of ``benchmarks/scale.py``. :func:`passes_warning` sums the pieces' outcomes
into one line per signal, with the range of what they reached.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

from gbpipe.harmonics.removal_inputs import Families, family_orders_checked

__all__ = ["crowded_orders", "Passes", "passes_warning"]


def crowded_orders(families: Families, shaft_hz: float, bandwidth_hz: float) -> list[str]:
    """The tracked orders that lie within two envelope bandwidths of each other, or within
    2.5 of 0 Hz (the mean's envelope), at a shaft speed: where the backfitting may diverge
    (``benchmarks/vkf_divergence.py``: a pass's spectral radius exceeds 1 there).

    Parameters
    ----------
    families : mapping
        Family name -> orders [HSS orders].
    shaft_hz, bandwidth_hz : float
        Shaft speed (the record's slowest: orders lie closest there) and half-power
        envelope bandwidth at that speed [Hz].

    Returns
    -------
    list of str
        One phrase per crowded pair, e.g. ``"mesh1 0.9022 and shaft 1 (0.33 Hz apart)"``.
    """
    named = sorted((float(o) * shaft_hz, f"{name} {float(o):.4g}")
                   for name, orders in family_orders_checked(families).items()
                   for o in orders)
    pairs = [(0.0, "the mean"), *named]
    return [f"{a} and {b} ({fb - fa:.2g} Hz apart)"
            for i, (fa, a) in enumerate(pairs) for fb, b in pairs[i + 1:]
            if fb - fa <= (2.5 if i == 0 else 2.0) * bandwidth_hz]


class Passes(NamedTuple):
    """How one piece's backfitting ended short of its tolerance.

    Attributes
    ----------
    diverged : bool
        Stopped as diverging (else it ran out of passes, ``max_iter``).
    least, at : float, int
        Its least residual change after the first pass [-] (of the harmonics found), and
        that pass.
    change, done : float, int
        Its last pass's change [-] and number.
    returned_least : bool
        The least pass's output was returned (the last one ended above it).
    """

    diverged: bool
    least: float
    at: int
    change: float
    done: int
    returned_least: bool


def _span(values: Sequence[float], fmt: str, noun: str = "") -> str:
    """The range of ``values``, each formatted with ``fmt``: ``"pass 5"`` or ``"passes 5 to
    8"`` with the ``noun`` "pass", ``"0.0025"`` or ``"between 0.0025 and 0.0041"`` without."""
    low, high = format(min(values), fmt), format(max(values), fmt)
    if low == high:
        return f"{noun} {low}".strip()
    return f"{noun}es {low} to {high}" if noun else f"between {low} and {high}"


def passes_warning(outcomes: Sequence[Passes | None], tol: float, max_iter: int,
                   crowd: str) -> str | None:
    """One warning for the pieces of a record whose passes missed ``tol``.

    Parameters
    ----------
    outcomes : sequence of Passes or None
        Per piece, in order: None where the passes reached the tolerance.
    tol : float
        The tolerance [-].
    max_iter : int
        Passes allowed.
    crowd : str
        The crowded orders (:func:`crowded_orders`, joined), or "" for none.

    Returns
    -------
    str or None
        What the pieces reached (the range over them), what was returned, and the advice:
        more passes, or, where orders crowd, a narrower bandwidth or the regression (more
        passes make those diverge further). None where every piece reached ``tol``.
    """
    missed = [o for o in outcomes if o is not None]
    if not missed:
        return None
    where = "" if len(outcomes) == 1 else f" in {len(missed)} of {len(outcomes)} pieces"
    parts = []
    grew = [o for o in missed if o.diverged]
    if grew:
        parts.append(
            f"diverges{'' if len(grew) == len(missed) else f' in {len(grew)} of them'}: the "
            f"residual change grew from {_span([o.least for o in grew], '.2g')} of the "
            f"harmonics found ({_span([o.at for o in grew], 'd', 'pass')}) to "
            f"{_span([o.change for o in grew], '.2g')} "
            f"({_span([o.done for o in grew], 'd', 'pass')})")
    slow = [o for o in missed if not o.diverged]
    if slow:
        parts.append(f"stopped after max_iter = {max_iter} passes"
                     f"{'' if len(slow) == len(missed) else f' in {len(slow)} of them'} with "
                     f"the residual still changing by {_span([o.change for o in slow], '.2g')}"
                     " of the harmonics found")
    least = [o for o in missed if o.returned_least]
    returned = ("" if not least else f", pass {least[0].at}'s output is returned"
                if len(outcomes) == 1 else
                ", each piece's least-changed pass is returned" if len(least) == len(outcomes)
                else f", the least-changed pass is returned in {len(least)} of them")
    advice = (f"orders within about a bandwidth of each other or of 0 Hz ({crowd}) need a "
              "narrower bandwidth (removal.vkf.bandwidth; decimate the record first if "
              "float64 refuses it) or the regression method" if crowd else
              "raise max_iter (removal.vkf.max_iter in the config)")
    return (f"Vold-Kalman backfitting{where} {'; '.join(parts)}; tol {tol:.2g} not reached"
            f"{returned}: {advice}")
