"""Designed-excitation test variants (``campaign.designed``): a ramp test plus a signal.

A designed test is its ``base`` ramp test (same profile, same set-points) with a
multisine or PRBS (:mod:`gbpipe.simulate.excitation`) added to one set-point:
``torque_ref`` [N·m] for ``setpoint: torque``, ``speed_ref`` for ``setpoint: speed``
(``rms`` in rpm there, the signal in rad/s in the record). The signal spans the whole
record from t = 0:

* multisine: lines ``k / period`` inside ``band``, Schroeder or random phases, ``rms``
  over each whole period (:func:`~gbpipe.simulate.excitation.multisine`);
* PRBS: ``+-rms`` bits at the clock ``fs / m`` with ``m = floor(0.3 fs / f_max)`` samples
  per bit, the highest such clock whose flat part (within 1.4 dB up to 0.3 of the clock)
  reaches the band's upper edge ``f_max``; ``f_min`` is not used.

Random phases and the PRBS register state come from ``SeedSequence(seed, (crc32(name),
seed_offset))``: the configuration seed, the test name and an optional offset.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from gbpipe.simulate.excitation import multisine, prbs
from gbpipe.simulate.profiles import PROFILES, RPM, TESTS, check_test, step_reference

__all__ = ["PRBS_FLAT", "test_names", "designed_spec", "base_test", "designed_setpoint",
           "designed_reference", "prbs_clock", "check_name"]

#: Share of its clock up to which a PRBS spectrum is flat within 1.4 dB.
PRBS_FLAT = 0.3


def _designed(cfg: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    return list(cfg["campaign"]["designed"])


def test_names(cfg: Mapping[str, Any]) -> list[str]:
    """Names of every configured test: ``campaign.tests``, then ``campaign.designed``."""
    return [*cfg["campaign"]["tests"], *(d["name"] for d in _designed(cfg))]


def designed_spec(cfg: Mapping[str, Any], name: str) -> tuple[int, Mapping[str, Any]] | None:
    """Index and entry of the designed test ``name`` in ``campaign.designed``, or None."""
    for i, d in enumerate(_designed(cfg)):
        if d["name"] == name:
            return i, d
    return None


def check_name(cfg: Mapping[str, Any], name: str, profile: str) -> None:
    """Refuse a name that is neither a ramp test nor a designed test, or a bad profile."""
    if designed_spec(cfg, name) is None:
        if name not in TESTS:
            names = [*TESTS, *(d["name"] for d in _designed(cfg))]
            raise ValueError(f"test: unknown test {name!r}; use one of {', '.join(names)}")
        check_test(name, profile)
    elif profile not in PROFILES:
        check_test(TESTS[0], profile)  # the profile's message


def base_test(cfg: Mapping[str, Any], name: str) -> str:
    """The ramp test a designed test is built on; a ramp test's name itself.

    Raises
    ------
    ValueError
        ``name`` is neither a ramp test nor in ``campaign.designed``.
    """
    found = designed_spec(cfg, name)
    if found is not None:
        return str(found[1]["base"])
    check_name(cfg, name, PROFILES[0])
    return name


def prbs_clock(fs: float, f_max: float) -> float:
    """PRBS bit rate [Hz]: ``fs / m``, ``m = floor(0.3 fs / f_max)`` samples per bit.

    Raises
    ------
    ValueError
        ``f_max > 0.3 fs``: no clock of a whole number of samples keeps the PRBS flat up
        to ``f_max``.
    """
    m = math.floor(PRBS_FLAT * fs / f_max * (1 + 1e-9))
    if m < 1:
        raise ValueError(f"band: a PRBS at fs = {fs:g} Hz is flat up to {PRBS_FLAT * fs:g} Hz "
                         f"at most; lower the upper band edge {f_max:g} Hz")
    return fs / m


def _seed(cfg: Mapping[str, Any], spec: Mapping[str, Any]) -> int:
    key = (zlib.crc32(str(spec["name"]).encode()), int(spec["seed_offset"]))
    return int(np.random.SeedSequence(int(cfg["seed"]), spawn_key=key).generate_state(1)[0])


def designed_setpoint(cfg: Mapping[str, Any], name: str, profile: str,
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The designed signal of one designed test, on the record's time axis.

    Parameters
    ----------
    cfg : mapping
        Validated configuration.
    name : str
        A name in ``campaign.designed``.
    profile : {"square", "tapered"}
        Profile of the base test (sets the record length).

    Returns
    -------
    t : ndarray
        Sample times [s] at ``campaign.sample_rate``.
    signal : ndarray
        The signal added to the set-point: N·m (torque) or rad/s (speed).

    Raises
    ------
    ValueError
        Not a designed test; a band, period or rms the signal cannot have (message led
        by the parameter name of :mod:`gbpipe.simulate.excitation`).
    """
    found = designed_spec(cfg, name)
    if found is None:
        raise ValueError(f"test: {name!r} is not in campaign.designed; use one of "
                         f"{', '.join(d['name'] for d in _designed(cfg)) or '(none)'}")
    spec = found[1]
    t, _, _ = step_reference(cfg["campaign"], spec["base"], profile)
    fs = float(cfg["campaign"]["sample_rate"])
    duration = t.size / fs
    scale = RPM if spec["setpoint"] == "speed" else 1.0
    rms = float(spec["rms"]) * scale
    f_min, f_max = (float(f) for f in spec["band"])
    if spec["signal"] == "multisine":
        x = multisine(fs, duration, f_min, f_max, rms, phases=spec["phases"],
                      frequency_resolution=1.0 / float(spec["period"]),
                      seed=_seed(cfg, spec))
    else:
        x = prbs(fs, duration, rms, clock_hz=prbs_clock(fs, f_max), seed=_seed(cfg, spec))
    return t, x


def designed_reference(cfg: Mapping[str, Any], name: str, profile: str,
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time axis [s], speed reference [rad/s] and torque reference [N·m] of any test.

    A ramp test's are :func:`~gbpipe.simulate.profiles.step_reference`; a designed
    test's are its base test's with :func:`designed_setpoint` added to its set-point.
    """
    check_name(cfg, name, profile)
    t, speed, torque = step_reference(cfg["campaign"], base_test(cfg, name), profile)
    found = designed_spec(cfg, name)
    if found is not None:
        _, x = designed_setpoint(cfg, name, profile)
        if found[1]["setpoint"] == "speed":
            speed = speed + x
        else:
            torque = torque + x
    return t, speed, torque
