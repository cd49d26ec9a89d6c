"""UDUNITS strings read by pint (for tests that check units independently of gbpipe)."""

from __future__ import annotations

import pint

UREG = pint.UnitRegistry()


def udunits_quantity(udunits: str) -> pint.Quantity:
    """1 of the unit ``udunits`` (space-separated factors with integer exponents, e.g.
    ``"rad s-1"``; ``"1"`` dimensionless), in base units."""
    if udunits == "1":
        return UREG.Quantity(1.0).to_base_units()
    factors = []
    for part in udunits.split():
        name = part.rstrip("-0123456789")
        factors.append(f"{name}**({part[len(name):] or '1'})")
    return UREG.Quantity(1.0, "*".join(factors)).to_base_units()
