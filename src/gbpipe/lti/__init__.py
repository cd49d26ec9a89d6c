"""The one LTI core of gbpipe: state-space type, exact simulator, FRF, fit metric, modes.

numpy and scipy only (python-control is imported by :mod:`gbpipe.lti.control_io`
alone, at the public boundary). See docs/architecture.md, "Package map".

Public API
----------
NamedSS
    State space with named signals and units; ``dt=None`` for continuous time.
dlsim(a, b, c, d, u, x0=None, *, return_state=False)
    Exact discrete simulation (block method, any conditioning).
lsim(sys, u, dt, x0=None, *, return_states=False)
    Zero-order-hold simulation of a continuous (or discrete) system: ``(y, x_final)``.
frf(sys, f_hz)
    Frequency response, shape (n_freq, n_outputs, n_inputs).
fit_percent(y, y_sim)
    NRMSE fit [%] per output.
modes(A, dt=None)
    Natural frequencies [Hz] and damping ratios.
pad(a, shape, fill=nan)
    ``a`` in the leading corner of a NaN array (models of unequal size on common dims).
"""

from gbpipe.lti.metrics import fit_percent
from gbpipe.lti.modal import modes
from gbpipe.lti.response import frf, pad
from gbpipe.lti.simulation import dlsim, lsim
from gbpipe.lti.statespace import NamedSS

__all__ = ["NamedSS", "dlsim", "lsim", "frf", "fit_percent", "modes", "pad"]
