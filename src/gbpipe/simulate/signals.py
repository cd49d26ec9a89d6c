"""The record contract of the simulator: which signals a test or sweep record holds.

Every record (``results/simulate/*.nc``, ``results/sweep/sweep.nc``) holds on ``time`` the
references ``speed_ref`` and ``torque_ref``, each signal of :data:`SIGNALS` clean and,
when measured-like, also as ``<name>_measured`` (harmonics and sensor noise added); the
sweep also ``rpm``. Configuration checks (``identify.pairings``, ``spectra.signal``) use
:func:`recorded_signals` so that a name is refused at load, not after a simulation.
See docs/architecture.md, "Data contract".
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Literal

__all__ = ["SIGNALS", "REFERENCES", "recorded_signals"]

#: Recorded signals: name -> (unit, long name, sensor kind used for its noise level).
SIGNALS: dict[str, tuple[str, str, str]] = {
    "motor_torque_driver": ("N m", "driver (driving) motor torque", "torque"),
    "motor_torque_driven": ("N m", "driven (braking) motor torque", "torque"),
    "torque_meter_driving": ("N m", "torque meter between driver motor and GB2 HSS", "torque"),
    "torque_meter_driven": ("N m", "torque meter between GB1 HSS and driven motor", "torque"),
    "speed_gb1_hss": ("rad/s", "GB1 (driven, multiplier) HSS speed", "speed"),
    "speed_gb2_hss": ("rad/s", "GB2 (driving, reducer) HSS speed", "speed"),
    "speed_lss": ("rad/s", "LSS speed (GB1 side)", "speed"),
}

#: Reference signals of every record.
REFERENCES = ("speed_ref", "torque_ref")


def recorded_signals(cfg: Mapping[str, Any], record: Literal["test", "sweep"] = "test",
                     ) -> list[str]:
    """Names of the time signals a record of this configuration holds.

    Parameters
    ----------
    cfg : mapping
        Validated configuration (``campaign.measured_like`` decides whether test records
        hold ``<name>_measured``; the sweep always does).
    record : {"test", "sweep"}
        A campaign test record or the speed sweep.

    Returns
    -------
    list of str
        References, clean signals, measured-like signals (and ``rpm`` for the sweep).
    """
    names = list(REFERENCES) + list(SIGNALS)
    if record == "sweep" or cfg["campaign"]["measured_like"]:
        names += [f"{n}_measured" for n in SIGNALS]
    if record == "sweep":
        names.append("rpm")
    return names
