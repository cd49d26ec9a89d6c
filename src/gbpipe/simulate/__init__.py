"""Simulated test campaigns and the speed sweep of the back-to-back bench.

Public API
----------
test(cfg, test, profile, measured_like=None)
    One closed-loop test record (clean and measured-like signals, tachometer pulses).
sweep(cfg)
    The constant-torque speed sweep.
random_only(cfg)
    The configuration with the angle-locked excitation off (the random-only records).
steady_state(ss, u0, omega0)
    Closed-loop state in steady rotation.
SIGNALS
    Recorded signals: name -> (unit, long name, sensor kind).

The simulator itself is :func:`gbpipe.lti.lsim`. See docs/architecture.md, "Stage graph".
"""

from gbpipe.simulate.campaign import SIGNALS, random_only, steady_state, sweep, test

__all__ = ["test", "sweep", "random_only", "steady_state", "SIGNALS"]
