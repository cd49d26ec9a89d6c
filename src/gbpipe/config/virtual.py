"""Cross-field checks of the ``virtual:`` section (docs/virtual.md): its records are bench
records, a fitted model has a fit, the noise window is a window, and the chosen sensors,
held-out sensors, shafts, mounts and disks are the chain's."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from gbpipe.errors import ConfigError
from gbpipe.model import bench_chain

__all__ = ["check_virtual"]


def check_virtual(cfg: Mapping[str, Any]) -> None:
    """Refuse a ``virtual:`` section that cannot run, naming the key and the fix.

    Raises
    ------
    gbpipe.errors.ConfigError
    """
    v = cfg["virtual"]
    if not v["records"]:
        return
    for i, r in enumerate(v["records"]):
        if r not in cfg["measured"]:
            raise ConfigError(f"virtual.records[{i}]", f"{r!r} is not a bench record; "
                              f"name one of measured: ({', '.join(cfg['measured']) or 'none'})")
        if v["model"] == "fitted" and r not in cfg["fit"]["records"]:
            raise ConfigError("virtual.model", f"fitted needs a fit of {r!r}: add it to "
                              "fit.records, or use virtual.model: configured")
    w = v["noise"]["window"]
    if not w[0] < w[1]:
        raise ConfigError("virtual.noise.window", f"[{w[0]}, {w[1]}] s is empty: give "
                          "[start, end] with start < end")
    chain = bench_chain(cfg)
    sensors = [*chain.speed_sensors, *chain.torque_sensors, *chain.angle_sensors]
    springs = [s.name for s in chain.mechanism.springs]
    disks = list(chain.mechanism.body_index)
    for key, known in (("sensors", sensors), ("holdout", sensors), ("torques", springs),
                       ("speeds", disks), ("loads", disks)):
        for i, name in enumerate(v[key]):
            if name not in known:
                raise ConfigError(f"virtual.{key}[{i}]", f"{name!r} is not one of the "
                                  f"chain's: {', '.join(known)}")
    both = set(v["sensors"]) & set(v["holdout"])
    if both:
        raise ConfigError("virtual.holdout", f"{', '.join(sorted(both))} both read and held "
                          "out: drop it from virtual.sensors")
