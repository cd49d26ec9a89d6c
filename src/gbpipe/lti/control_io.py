"""Conversion between :class:`gbpipe.lti.NamedSS` and ``control.StateSpace``.

The only module of :mod:`gbpipe.lti` that imports python-control (about 3 s to import):
the rest of gbpipe works on :class:`NamedSS` and pays nothing for it.
"""

from __future__ import annotations

import control
import numpy as np

from gbpipe.lti.statespace import NamedSS

__all__ = ["to_control", "from_control"]


def to_control(ss: NamedSS, name: str | None = None) -> control.StateSpace:
    """Named ``control.StateSpace`` of a :class:`NamedSS` (same time base).

    Parameters
    ----------
    ss : NamedSS
    name : str, optional
        System name given to python-control.
    """
    dt = 0 if ss.dt is None else ss.dt
    return control.ss(ss.A, ss.B, ss.C, ss.D, dt, inputs=list(ss.inputs),
                      outputs=list(ss.outputs), states=list(ss.states), name=name)


def from_control(sys: control.LTI) -> NamedSS:
    """:class:`NamedSS` of a python-control system (converted with ``control.ss``).

    Signal names are kept; units are unknown (empty). Continuous systems (``dt == 0``)
    get ``dt=None``; a discrete system with unspecified sampling time (``dt is True``)
    gets ``dt=1.0``.
    """
    s = control.ss(sys)
    dt = None if not s.isdtime(strict=True) else (1.0 if s.dt is True else float(s.dt))
    return NamedSS(np.asarray(s.A, dtype=float), np.asarray(s.B, dtype=float),
                   np.asarray(s.C, dtype=float), np.asarray(s.D, dtype=float),
                   list(s.state_labels), list(s.input_labels), list(s.output_labels),
                   {}, dt)
