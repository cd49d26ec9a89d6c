"""gbpipe: data-driven dynamic models of wind-turbine gearboxes.

Torsional models of multi-stage gearboxes and back-to-back test benches, simulated test
campaigns, harmonic removal by time synchronous averaging, and subspace identification.
Sub-modules are imported lazily so that ``import gbpipe`` stays cheap.
"""

from importlib import import_module
from typing import Any

__version__ = "0.1.0"

_SUBMODULES = {
    "config", "io", "kinematics", "model", "simulate", "orders", "spectra", "tsa",
    "sysid", "identify", "figures", "removal",
}


def __getattr__(name: str) -> Any:
    # Lazy sub-module import: `import control` alone costs seconds, and each Snakemake
    # job pays the imports of what it touches only.
    if name in _SUBMODULES:
        return import_module(f"gbpipe.{name}")
    raise AttributeError(f"module 'gbpipe' has no attribute {name!r}")
