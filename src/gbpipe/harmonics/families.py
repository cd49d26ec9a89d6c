"""Harmonic families: exact cycle orders, the configured excitation orders, which of them
a cycle removes, and the structural modes a removal must leave alone.

Which excitation orders a TSA variant removes is decided exactly: a configured excitation
order ``o`` (shaft order or mesh harmonic, a Fraction from the teeth) is removed by a
cycle of order ``c`` when ``o / c`` is a whole number. Those are the families whose
attenuation is measured and whose crossings of a structural mode are flagged.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from fractions import Fraction
from typing import Any

import numpy as np

from gbpipe.harmonics.checks import as_order, as_positive
from gbpipe.kinematics import excitation_lines, order_of, pulsating_orders, whole_multiple

__all__ = ["family_orders", "cycle_orders", "family_names", "excitation_families",
           "removed_families", "test_families", "structural_modes"]


def family_orders(cycle_order: float | Fraction, max_order: float) -> np.ndarray:
    """Harmonics ``k * cycle_order`` (k = 1, 2, ...) up to ``max_order``.

    Parameters
    ----------
    cycle_order : float or Fraction
        Fundamental order of the family [HSS orders], > 0.
    max_order : float
        Highest order [-].

    Returns
    -------
    numpy.ndarray
        The orders [-]; computed from the Fraction when one is given (no drift).
    """
    c = as_order(cycle_order)
    max_order = as_positive(max_order, "max_order", "orders")
    k = np.arange(1, int(np.floor(max_order / c + 1e-12)) + 1)
    if isinstance(cycle_order, Fraction):
        return np.array([float(cycle_order * int(i)) for i in k])
    return k * c


def structural_modes(freqs: Sequence[float], f_min: float, f_max: float,
                     merge_within: float) -> np.ndarray:
    """Mode frequencies [Hz] to watch, in ``(f_min, f_max)``, close pairs merged.

    The bench's twin gearboxes give pairs of modes a fraction of a hertz apart (61.9 and
    62.4 Hz); one band covers both, so pairs closer than ``merge_within`` become their mean.
    """
    f = np.sort(np.asarray(freqs, dtype=float))
    f = f[(f > f_min) & (f < f_max)]
    groups: list[list[float]] = []
    for v in f:
        if groups and v - groups[-1][-1] < merge_within:
            groups[-1].append(v)
        else:
            groups.append([v])
    return np.array([np.mean(g) for g in groups])


def cycle_orders(stages: Sequence[Mapping[str, Any]], cycles: Sequence[str]) -> list[Fraction]:
    """Exact HSS orders of named cycles (``hss``, ``carrier2``, ``mesh2`` …).

    Parameters
    ----------
    stages : sequence of mapping
        ``cfg["gearbox"]["stages"]``.
    cycles : sequence of str
        Shaft, member or mesh names of :func:`gbpipe.kinematics.order_of`.
    """
    return [order_of(stages, c) for c in cycles]


def family_names(stages: Sequence[Mapping[str, Any]]) -> list[str]:
    """Every family a bench can have: ``shaft``, ``mesh<k>`` per stage (k from 1), then
    ``motor`` (the converter's pulsating torque)."""
    return ["shaft", *(f"mesh{k}" for k in range(1, len(stages) + 1)), "motor"]


def excitation_families(cfg: Mapping[str, Any]) -> dict[str, list[Fraction]]:
    """Orders of every configured excitation, grouped by source.

    Parameters
    ----------
    cfg : mapping
        ``gearbox.stages`` and ``excitation``; with ``noise`` (the record's noise section:
        ``noise``, or ``sweep.noise`` for the sweep) also the motors' pulsating torque.

    Returns
    -------
    dict
        ``"shaft"`` → HSS orders of the shaft excitation; ``"mesh<k>"`` → the harmonics of
        stage k's mesh order; ``"motor"`` → the orders ``harmonic x pole_pairs`` of the
        converters' pulsating torque (both motors turn at the HSS speed), all as Fractions.
        The pulsating torque is locked to the shaft angle like the gear excitation, so it
        is harmonic content, removed with it and absent from the random-only records.
    """
    fam = {name: [order for order, amplitude in lines if amplitude > 0]
           for name, lines in excitation_lines(cfg["excitation"],
                                               cfg["gearbox"]["stages"]).items()}
    if "noise" in cfg:
        fam["motor"] = sorted({Fraction(order)
                               for spec in cfg["noise"]["motor_ripple"].values()
                               for order, amplitude in pulsating_orders(spec)
                               if amplitude > 0})
    return {k: v for k, v in fam.items() if v}


def removed_families(families: Mapping[str, Sequence[Fraction]],
                     cycles: Sequence[Fraction]) -> dict[str, list[Fraction]]:
    """The part of each family that is a whole multiple of one of the cycles.

    Exact: an order ``o`` is removed by a cycle ``c`` when ``o / c`` is an integer
    (Fractions from the teeth, no tolerance). Families with nothing removed are dropped.
    """
    out = {}
    for name, orders in families.items():
        kept = [o for o in orders if whole_multiple(o, cycles)]
        if kept:
            out[name] = kept
    return out


def test_families(cfg: Mapping[str, Any]) -> dict[str, list[Fraction]]:
    """The excitation families that the ``removal.tests`` cycles remove: what every
    harmonic-removal version of identification but TSA takes off the tests (TSA removes
    those of ``tsa.tests``; ``removal.tests`` defaults to it)."""
    return removed_families(excitation_families(cfg),
                            cycle_orders(cfg["gearbox"]["stages"], cfg["removal"]["tests"]))

