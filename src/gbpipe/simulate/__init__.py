"""Simulated test campaigns and the speed sweep of the back-to-back bench.

Public API
----------
test(cfg, test, profile, measured_like=None)
    One closed-loop test record (clean and measured-like signals, tachometer pulses) of a
    ramp test or a designed test (``campaign.designed``).
test_names(cfg), base_test(cfg, name)
    Every configured test name (ramp tests, then designed); a designed test's ramp test.
designed_setpoint(cfg, name, profile), designed_reference(cfg, name, profile)
    A designed test's signal on its set-point; any test's speed and torque references.
sweep(cfg)
    The constant-torque speed sweep.
random_only(cfg)
    The configuration with the angle-locked excitation off (the random-only records).
steady_state(ss, u0, omega0)
    Closed-loop state in steady rotation.
SIGNALS
    Recorded signals: name -> (unit, long name, sensor kind).
multisine(fs, duration, f_min, f_max, rms), prbs(fs, duration, amplitude, clock_hz=...)
    Designed excitation to superpose on a set-point (:mod:`.excitation`).
within_limits(reference, excitation, limit, name, fs=None)
    Refuse an excitation that drives the set-point beyond a limit.

The simulator itself is :func:`gbpipe.lti.lsim`. See docs/architecture.md, "Stage graph".
"""

from gbpipe.simulate.campaign import SIGNALS, random_only, steady_state, sweep, test
from gbpipe.simulate.designed import (
    base_test,
    designed_reference,
    designed_setpoint,
    test_names,
)
from gbpipe.simulate.excitation import multisine, prbs, within_limits

__all__ = ["test", "sweep", "random_only", "steady_state", "SIGNALS", "test_names",
           "base_test", "designed_setpoint", "designed_reference",
           "multisine", "prbs", "within_limits"]
