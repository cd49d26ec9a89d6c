"""Unit constants and the unit strings gbpipe writes (SI inside, always).

A leaf module: it imports nothing of gbpipe. Conversions that appear in more than one
place live here once, so a reader finds every ``2π/60`` in one spot.
"""

from __future__ import annotations

import math

__all__ = ["RAD_S_PER_RPM", "RPM_PER_RAD_S", "TWO_PI", "squared_units", "label_units"]

TWO_PI = 2.0 * math.pi
#: rad/s per rev/min
RAD_S_PER_RPM = TWO_PI / 60.0
#: rev/min per rad/s
RPM_PER_RAD_S = 60.0 / TWO_PI


_SUPERSCRIPT = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")


def _factors(units: str) -> list[tuple[str, int]] | None:
    """``"rad s-1"`` → ``[("rad", 1), ("s", -1)]``; None unless every space-separated
    factor is a name with an optional integer exponent."""
    out = []
    for part in units.split():
        name = part.rstrip("-0123456789")
        exp_txt = part[len(name):]
        if not name.isalpha() or (exp_txt and not exp_txt.lstrip("-").isdigit()):
            return None
        out.append((name, int(exp_txt) if exp_txt else 1))
    return out


def label_units(units: str) -> str:
    """A UDUNITS string as a person writes it in a label.

    ``"N m"`` → ``"N·m"``, ``"rad s-1"`` → ``"rad/s"``, ``"kg m2"`` → ``"kg·m²"``,
    ``"N m s rad-1"`` → ``"N·m·s/rad"``; anything else (already readable, e.g. ``"rad/s"``)
    is returned as is.
    """
    factors = _factors(units.strip())
    if not factors:
        return units

    def join(fs: list[tuple[str, int]]) -> str:
        return "·".join(n + (str(e).translate(_SUPERSCRIPT) if e != 1 else "") for n, e in fs)

    num = join([(n, e) for n, e in factors if e > 0]) or "1"
    den = [(n, -e) for n, e in factors if e < 0]
    if not den:
        return num
    return f"{num}/{join(den) if len(den) == 1 else '(' + join(den) + ')'}"


def squared_units(units: str) -> str:
    """UDUNITS string of ``units`` squared (the unit of a power spectrum of a signal).

    ``"N m"`` → ``"N2 m2"``, ``"rad s-1"`` → ``"rad2 s-2"``; space-separated factors with
    optional integer exponents are squared factor by factor, anything else becomes
    ``"(units)^2"``.
    """
    u = units.strip()
    if u in ("", "1", "-"):
        return "1"
    factors = _factors(u)
    if factors is None:
        return f"({u})^2"
    return " ".join(f"{name}{2 * exp}" for name, exp in factors)
