"""Tests of gbpipe.harmonics.removal (the method table) and the family cycles, against
hand-computed cycles and the TSA functions called directly."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from removal_signals import FAMILIES, db, inner, sweep

from gbpipe.errors import DataError
from gbpipe.harmonics import residual_joint
from gbpipe.harmonics.removal import METHODS, MULTICHANNEL, family_cycles, remove_harmonics
from gbpipe.harmonics.removal_inputs import family_cycle


def test_family_cycle_is_the_gcd():
    mesh = Fraction(609 * 114, 12960)  # a mesh order as a Fraction of the teeth
    assert family_cycle([mesh, 2 * mesh, 3 * mesh]) == mesh
    assert family_cycle([Fraction(3, 2), 3]) == Fraction(3, 2)
    assert family_cycle([2.0, 4.0, 6.0]) == 2


def test_family_cycles_drop_multiples():
    # mesh3 at 29 HSS orders is a harmonic of the HSS cycle: TSA of 1 already removes it
    cyc = family_cycles({"shaft": [1, 2, 3], "mesh3": [29, 58], "mesh2": [Fraction(5, 2)]})
    assert cyc == [Fraction(1), Fraction(5, 2)]


def test_tsa_entry_is_residual_joint_of_the_cycles():
    sw = sweep(noise=0.1)
    r = remove_harmonics("tsa", sw["x"], sw["fs"], sw["pulses"], FAMILIES, n_cycles=10)
    cycles = [1.0, family_cycle(FAMILIES["mesh"])]
    ref = residual_joint(sw["x"], sw["fs"], sw["pulses"], cycles, 10)
    np.testing.assert_allclose(r, ref, atol=1e-12)


@pytest.mark.parametrize("name", ["vkf", "regression", "drs", "cepstrum"])
def test_every_method_removes_through_the_table(name):
    sw = sweep(noise=0.01)
    r = remove_harmonics(name, sw["x"], sw["fs"], sw["pulses"], FAMILIES)
    m = inner(sw["t"], sw["pulses"], 1.0)
    assert db(np.mean(sw["h"][m] ** 2), np.mean((r - sw["res"])[m] ** 2)) >= 15.0


def test_unknown_method():
    assert set(METHODS) == {"tsa", "vkf", "regression", "drs", "cepstrum"}
    with pytest.raises(ValueError, match="unknown"):
        remove_harmonics("wavelet", np.zeros(10), 1.0, np.arange(3.0), FAMILIES)


@pytest.mark.parametrize("name", sorted(METHODS))
def test_channels_at_once_equal_each_channel_alone(name):
    # three channels of one record (one pulse train): the harmonics with two noise
    # levels and a scaled copy; each column's residual is the one-channel residual
    sw = sweep(noise=0.05)
    rng = np.random.default_rng(7)
    x = np.column_stack([sw["x"], sw["h"] + 0.3 * rng.standard_normal(sw["x"].size),
                         -40.0 * sw["x"]])
    r = remove_harmonics(name, x, sw["fs"], sw["pulses"], FAMILIES)
    assert r.shape == x.shape
    for j in range(x.shape[1]):
        alone = remove_harmonics(name, x[:, j], sw["fs"], sw["pulses"], FAMILIES)
        if name in MULTICHANNEL:  # shared factor: equal to rounding of the BLAS order
            scale = np.max(np.abs(x[:, j]))
            np.testing.assert_allclose(r[:, j], alone, rtol=0, atol=1e-11 * scale)
        else:  # the columns one by one
            np.testing.assert_array_equal(r[:, j], alone)


def test_a_bad_channel_is_named():
    sw = sweep(noise=0.05)
    x = np.column_stack([sw["x"], sw["x"]])
    x[1234, 1] = np.nan
    with pytest.raises(DataError, match=r"x\[:, 1\].*first at index 1234"):
        remove_harmonics("regression", x, sw["fs"], sw["pulses"], FAMILIES)


@pytest.mark.parametrize("name", ["vkf", "regression"])
def test_records_at_once_equal_each_record_alone(name):
    # a record and its harmonic part (one angle), two channels each: every record's
    # residual is the one of its own call, bit for bit (removal_tests runs them at once);
    # the regression with a modal envelope (its dense border) and a second angle
    sw = sweep(noise=0.05, duration=8.0)
    rng = np.random.default_rng(11)
    x = np.column_stack([sw["x"], -3.0 * sw["x"] + 0.2 * rng.standard_normal(sw["x"].size)])
    records = np.stack([x, np.column_stack([sw["h"], -3.0 * sw["h"]])])
    params = ({"modes": [(62.0, 0.03)], "knot_spacing": {"shaft": 0.5, "default": 1.0},
               "twist": 0.05 * np.sin(2 * np.pi * 1.3 * sw["t"])}
              if name == "regression" else {})
    r = remove_harmonics(name, records, sw["fs"], sw["pulses"], FAMILIES, **params)
    assert r.shape == records.shape
    for k in range(records.shape[0]):
        alone = remove_harmonics(name, records[k], sw["fs"], sw["pulses"], FAMILIES, **params)
        np.testing.assert_array_equal(r[k], alone)
    assert np.any(r != records)  # something was removed
