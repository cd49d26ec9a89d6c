"""The one state-space type of gbpipe: plain numpy matrices with signal names and units.

``python-control`` objects appear only at the public boundary
(:mod:`gbpipe.lti.control_io`); everything inside gbpipe passes :class:`NamedSS`.
See docs/architecture.md, "Package map".
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

__all__ = ["NamedSS"]


@dataclass
class NamedSS:
    """State space ``x' = A x + B u, y = C x + D u`` with names and units.

    Attributes
    ----------
    A, B, C, D : ndarray
        Shapes (n, n), (n, m), (p, n), (p, m).
    states, inputs, outputs : list of str
        Names of the n states, m inputs and p outputs.
    units : dict
        Signal name -> unit string, for every input, output and state.
    dt : float or None
        None: continuous time (``x' = dx/dt``). A float: discrete time with sample
        interval ``dt`` [s] (``x' = x[k+1]``).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    states: list[str]
    inputs: list[str]
    outputs: list[str]
    units: dict[str, str] = field(default_factory=dict)
    dt: float | None = None

    def index(self, kind: str, name: str) -> int:
        """Position of the ``kind`` ("input", "output" or "state") called ``name``.

        Raises
        ------
        ValueError
            Unknown kind or name; the message lists the available names.
        """
        names = {"input": self.inputs, "output": self.outputs, "state": self.states}[kind]
        if name not in names:
            raise ValueError(f"unknown {kind} {name!r}; available: {', '.join(names)}")
        return names.index(name)

    def select(self, inputs: list[str] | None = None,
               outputs: list[str] | None = None) -> NamedSS:
        """Sub-system from chosen inputs to chosen outputs (all states kept).

        Parameters
        ----------
        inputs, outputs : list of str, optional
            Names, in the wanted order; None keeps all.
        """
        ii = [self.index("input", n) for n in (inputs or self.inputs)]
        oo = [self.index("output", n) for n in (outputs or self.outputs)]
        return replace(self, B=self.B[:, ii], C=self.C[oo], D=self.D[np.ix_(oo, ii)],
                       inputs=[self.inputs[i] for i in ii],
                       outputs=[self.outputs[o] for o in oo], units=dict(self.units),
                       states=list(self.states))

    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` (in s for continuous time, in z for discrete time)."""
        return np.linalg.eigvals(self.A)
