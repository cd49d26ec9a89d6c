"""Cross-field checks of the designed-excitation tests (``campaign.designed``).

Refused at load, before any simulation: a name used twice or equal to a ramp test's (the
record files ``{name}_{profile}.nc`` would collide), a base test not in
``campaign.tests``, a band not inside (0, Nyquist) or reversed, multisine-only keys on a
PRBS, any signal :mod:`gbpipe.simulate.excitation` cannot build for a configured profile
(period longer than the record, no line in the band, PRBS clock), and a torque set-point
whose reference plus signal exceeds ``bench.torque_limit.driven`` (the braking motor
follows the torque reference through its feed-forward). The predicted torque of *both*
motors, which a speed set-point needs, is checked on the simulation
(:func:`gbpipe.simulate.test`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from gbpipe.config.scope import simulated
from gbpipe.errors import ConfigError, ExcitationError
from gbpipe.simulate.designed import designed_setpoint
from gbpipe.simulate.excitation import within_limits
from gbpipe.simulate.profiles import TESTS, step_reference

__all__ = ["check_designed"]

#: parameter named by a :mod:`gbpipe.simulate.excitation` error -> its configuration key
_KEY_OF = {"f_min": "band", "f_max": "band", "band": "band", "clock_hz": "band",
           "frequency_resolution": "period", "duration": "period", "rms": "rms"}


def _check_entry(cfg: Mapping[str, Any], i: int, spec: Mapping[str, Any]) -> None:
    field = f"campaign.designed[{i}]"
    camp = cfg["campaign"]
    if spec["base"] not in camp["tests"]:
        raise ConfigError(f"{field}.base", f"'{spec['base']}' is not in campaign.tests "
                          f"{camp['tests']}; add it there or pick one of them")
    if spec["signal"] == "prbs":
        for key in ("phases", "period"):
            if key in spec:
                raise ConfigError(f"{field}.{key}", "applies to a multisine only; drop it "
                                  "(a PRBS's clock follows the band's upper edge)")
    f_min, f_max = (float(f) for f in spec["band"])
    nyquist = float(camp["sample_rate"]) / 2
    if not f_min < f_max < nyquist:
        raise ConfigError(f"{field}.band", f"[{f_min:g}, {f_max:g}] Hz must satisfy "
                          f"0 <= f_min < f_max < the Nyquist frequency {nyquist:g} Hz of "
                          "campaign.sample_rate")
    for profile in camp["profiles"]:
        try:
            _, x = designed_setpoint(cfg, spec["name"], profile)
        except ValueError as exc:
            param = str(exc).split(":", 1)[0]
            raise ConfigError(f"{field}.{_KEY_OF.get(param, 'band')}",
                              f"{spec['signal']} of {spec['name']} ({profile}): {exc}") from None
        if spec["setpoint"] != "torque":
            continue
        _, _, torque = step_reference(camp, spec["base"], profile)
        limit = float(cfg["bench"]["torque_limit"]["driven"])
        try:
            within_limits(torque, x, limit, "torque_ref", float(camp["sample_rate"]))
        except ExcitationError as exc:
            raise ConfigError(f"{field}.rms", f"{spec['name']} ({profile}): {exc} — the "
                              "driven motor follows the torque reference; or raise "
                              "bench.torque_limit.driven if the motor allows it") from None


def check_designed(cfg: Mapping[str, Any]) -> None:
    """Check every entry of ``campaign.designed`` (names, base, band, signal, limit).

    Only when the campaign is simulated (:func:`~gbpipe.config.scope.simulated`).
    """
    if not simulated(cfg):
        return
    seen: set[str] = set()
    for i, spec in enumerate(cfg["campaign"]["designed"]):
        name = spec["name"]
        if name in TESTS or name in seen:
            what = "a ramp test's" if name in TESTS else "an earlier designed test's"
            raise ConfigError(f"campaign.designed[{i}].name", f"'{name}' is {what} name: "
                              "records are {name}_{profile}.nc, so names must be unique")
        seen.add(name)
        _check_entry(cfg, i, spec)
