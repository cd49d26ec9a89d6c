"""Unit strings: the labels written from UDUNITS strings mean the same unit (checked with
pint, independently of gbpipe's parser)."""

from __future__ import annotations

import pytest

from gbpipe.units import label_units, squared_units
from tests.pint_units import UREG, udunits_quantity

_POWERS = str.maketrans({"·": "*", "²": "**2", "³": "**3", "⁴": "**4"})


@pytest.mark.parametrize("units", ["N m", "rad s-1", "kg m2", "N m s rad-1", "m s-2 kg-1",
                                   "N2 m2", "rad2 s-2 Hz-1"])
def test_label_is_the_same_unit(units):
    label = label_units(units)
    assert " " not in label
    assert UREG.Quantity(1.0, label.translate(_POWERS)).to_base_units() == \
        udunits_quantity(units)


def test_readable_strings_are_kept_and_squares_are_squares():
    assert label_units("rad/s") == "rad/s" and label_units("1") == "1"
    for units in ("N m", "rad s-1", "N m s rad-1"):
        assert udunits_quantity(squared_units(units)) == udunits_quantity(units) ** 2
