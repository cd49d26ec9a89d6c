"""Several stabilization diagrams read as one, each where it is believed (zoom).

A model of a few dozen states spread over 0-Nyquist spends them where the response is
strong and fits a lightly excited low end poorly; the diagram of the same data decimated
holds the low end with the same orders. :func:`select_poles` keeps, order by order, the
poles of one diagram in the frequencies it is believed in; :func:`join_poles` joins such
parts into one diagram's poles, which :func:`gbpipe.sysid.stabilize` reads as any other
(:mod:`gbpipe.identify.modal_diagrams` does this for a bench record).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from gbpipe.errors import ConfigError
from gbpipe.sysid.stabilization import PoleSet

__all__ = ["select_poles", "join_poles"]


def select_poles(poles: list[PoleSet], keep: Callable[[np.ndarray], np.ndarray]
                 ) -> list[PoleSet]:
    """Per order, the poles whose frequency [Hz] ``keep`` (frequencies -> bool) accepts."""
    out = []
    for f, z, v in poles:
        m = np.asarray(keep(f), dtype=bool)
        out.append((f[m], z[m], v[m]))
    return out


def join_poles(parts: Sequence[list[PoleSet]]) -> list[PoleSet]:
    """One diagram of the poles of several, order by order (ascending in frequency).

    A model of a few dozen states spread over 0-Nyquist spends them where the response is
    strong and fits a lightly excited low end poorly; a diagram of the same data decimated
    holds the low end with the same orders (zoom). Each part is one diagram's poles where
    it is to be believed (:func:`select_poles`); joined, they are read as one diagram
    (:func:`stabilize`).

    Parameters
    ----------
    parts : sequence of list of (frequency_hz, damping, shape)
        Per diagram, its poles per order: the same orders and channels in every part.

    Returns
    -------
    list of (frequency_hz, damping, shape)
    """
    if len({len(p) for p in parts}) > 1:
        raise ConfigError("parts", "every diagram joined needs the same orders")
    out = []
    for per_order in zip(*parts, strict=True):
        f = np.concatenate([p[0] for p in per_order])
        rank = np.argsort(f, kind="stable")
        out.append((f[rank], np.concatenate([p[1] for p in per_order])[rank],
                    np.concatenate([p[2] for p in per_order], axis=0)[rank]))
    return out
