"""Unit constants and the unit strings gbpipe writes (SI inside, always).

A leaf module: it imports nothing of gbpipe. Conversions that appear in more than one
place live here once, so a reader finds every ``2π/60`` in one spot.
"""

from __future__ import annotations

import math

__all__ = ["RAD_S_PER_RPM", "RPM_PER_RAD_S", "TWO_PI", "squared_units"]

TWO_PI = 2.0 * math.pi
#: rad/s per rev/min
RAD_S_PER_RPM = TWO_PI / 60.0
#: rev/min per rad/s
RPM_PER_RAD_S = 60.0 / TWO_PI


def squared_units(units: str) -> str:
    """UDUNITS string of ``units`` squared (the unit of a power spectrum of a signal).

    ``"N m"`` → ``"N2 m2"``, ``"rad s-1"`` → ``"rad2 s-2"``; space-separated factors with
    optional integer exponents are squared factor by factor, anything else becomes
    ``"(units)^2"``.
    """
    u = units.strip()
    if u in ("", "1", "-"):
        return "1"
    out = []
    for part in u.split():
        name = part.rstrip("-0123456789")
        exp_txt = part[len(name):]
        if not name.isalpha() or (exp_txt and not exp_txt.lstrip("-").isdigit()):
            return f"({u})^2"
        exp = int(exp_txt) if exp_txt else 1
        out.append(f"{name}{2 * exp}")
    return " ".join(out)
