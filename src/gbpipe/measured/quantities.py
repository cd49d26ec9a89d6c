"""Units of bench channels, parsed by pint and converted to the SI units gbpipe stores.

A unit string (``N*m``, ``kN*m``, ``rpm``, ``deg``, ``rad/s``, ``mV``…) is parsed once,
its dimensionality picks the SI unit of :data:`SI_UNITS`, and :func:`to_si` returns the
factor and offset (offset only for temperatures) that take values there. Angles: pint
treats the radian as a dimensionless base unit, so ``rpm``, ``deg/s`` and ``rev/s``
become ``rad/s``; a bare ``Hz`` or ``1/s`` stays ``Hz`` (it does not say whether it
counts revolutions or radians).
"""

from __future__ import annotations

import re
from functools import lru_cache

import pint

from gbpipe.errors import DataError

__all__ = ["to_si", "SI_UNITS", "ALIASES", "registry"]

#: SI units gbpipe stores: (pint unit, unit string written), found by dimensionality
SI_UNITS = (("N*m", "N m"), ("N", "N"), ("m", "m"), ("m/s", "m/s"), ("m/s**2", "m/s2"),
            ("s", "s"), ("V", "V"), ("A", "A"), ("W", "W"), ("Pa", "Pa"), ("K", "K"),
            ("Hz", "Hz"), ("kg", "kg"))
#: SI units of angle-bearing quantities (pint's radian is a dimensionless base unit)
_ANGLE_UNITS = (("rad", "rad"), ("rad/s", "rad/s"), ("rad/s**2", "rad/s2"))


#: spellings bench software writes that pint lacks or reads otherwise ("Nm" is a
#: nautical-mile-like unit to pint), replaced as whole words before parsing
ALIASES = {"Nm": "N*m", "kNm": "kN*m", "rev": "revolution", "U/min": "rpm"}
_ALIAS_RE = re.compile(r"(?<![\w/])(" + "|".join(re.escape(a) for a in ALIASES) + r")(?!\w)")


@lru_cache(maxsize=1)
def registry() -> pint.UnitRegistry:
    """The one pint registry (building it takes ~0.3 s)."""
    return pint.UnitRegistry()


@lru_cache(maxsize=256)
def to_si(unit: str, source: str = "") -> tuple[float, float, str]:
    """Factor, offset and SI unit string such that ``si = factor * x + offset``.

    Parameters
    ----------
    unit : str
        Unit of the values, in pint syntax.
    source : str
        ``file: channel``, for the error message.

    Raises
    ------
    gbpipe.errors.DataError
        For a unit pint cannot parse, or one whose dimension gbpipe has no SI unit for.
    """
    ureg = registry()
    where = f"{source}: field 'unit'" if source else "field 'unit'"
    text = _ALIAS_RE.sub(lambda m: ALIASES[m[1]], unit.strip())
    try:
        u = ureg.Unit(text) if text not in ("", "1", "-") else ureg.Unit("")
    except (pint.errors.UndefinedUnitError, pint.errors.DefinitionSyntaxError,
            AttributeError, TypeError, ValueError, AssertionError) as exc:
        raise DataError(where, f"unknown unit {unit!r} ({exc}); use pint syntax such as "
                        "N*m, kN*m, rpm, deg, rad/s, V") from exc
    dim = u.dimensionality
    angle = "radian" in str(ureg.Quantity(1.0, u).to_base_units().units)
    table = (_ANGLE_UNITS if angle else ()) + SI_UNITS
    match = [(t, lab) for t, lab in table if ureg.Unit(t).dimensionality == dim]
    if match:
        target, label = match[0]
    elif not dim:
        target, label = "", "1"
    else:
        raise DataError(where, f"unit {unit!r} has dimension {dim}, for which gbpipe has "
                        f"no SI unit; known: {', '.join(lab for _, lab in SI_UNITS)}")
    q0 = ureg.Quantity(0.0, u).to(target).magnitude
    q1 = ureg.Quantity(1.0, u).to(target).magnitude
    return float(q1 - q0), float(q0), label
