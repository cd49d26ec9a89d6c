"""The gearbox and bench models as named ``control.StateSpace`` objects.

The public boundary to python-control: importing this module imports python-control
(about 3 s). gbpipe itself uses the numpy forms :func:`gbpipe.model.gearbox_ss` and
:func:`gbpipe.model.bench_ss`. Usage::

    from gbpipe.model.control_models import gearbox, bench
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import control

from gbpipe.lti.control_io import to_control
from gbpipe.model.assembly import bench_ss, gearbox_ss

__all__ = ["gearbox", "bench"]


def gearbox(cfg: Mapping[str, Any]) -> control.StateSpace:
    """:func:`gbpipe.model.gearbox_ss` as a named ``control.StateSpace`` (same signals;
    Figure 3 is ``torque_hss → speed_lss``)."""
    return to_control(gearbox_ss(cfg), name="gearbox")


def bench(cfg: Mapping[str, Any], closed: bool = True) -> control.StateSpace:
    """State-space model of the complete back-to-back bench.

    Parameters
    ----------
    cfg : mapping
        Validated configuration.
    closed : bool, default True
        Close the speed and braking-torque loops (see :func:`gbpipe.model.bench_ss` for
        the signals).

    Returns
    -------
    control.StateSpace
    """
    return to_control(bench_ss(cfg, closed), name="bench" if closed else "bench_plant")
