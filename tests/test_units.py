"""Unit strings: the labels written from UDUNITS strings mean the same unit (checked with
pint, independently of gbpipe's parser)."""

from __future__ import annotations

import pint
import pytest

from gbpipe.units import label_units, squared_units

UREG = pint.UnitRegistry()
_POWERS = str.maketrans({"·": "*", "²": "**2", "³": "**3", "⁴": "**4"})


def _pint_udunits(units: str) -> pint.Unit:
    # UDUNITS: space-separated factors with integer exponents ("rad s-1")
    expr = []
    for part in units.split():
        name = part.rstrip("-0123456789")
        exp = part[len(name):] or "1"
        expr.append(f"{name}**({exp})")
    return UREG.Quantity(1.0, "*".join(expr)).to_base_units()


@pytest.mark.parametrize("units", ["N m", "rad s-1", "kg m2", "N m s rad-1", "m s-2 kg-1",
                                   "N2 m2", "rad2 s-2 Hz-1"])
def test_label_is_the_same_unit(units):
    label = label_units(units)
    assert " " not in label
    assert UREG.Quantity(1.0, label.translate(_POWERS)).to_base_units() == \
        _pint_udunits(units)


def test_readable_strings_are_kept_and_squares_are_squares():
    assert label_units("rad/s") == "rad/s" and label_units("1") == "1"
    for units in ("N m", "rad s-1", "N m s rad-1"):
        assert _pint_udunits(squared_units(units)) == _pint_udunits(units) ** 2
