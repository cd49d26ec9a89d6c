"""The record-contract accessors: measured form of a signal, tacho speed, split records."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from gbpipe.errors import DataError
from gbpipe.io import longest_segment, mean_shaft_frequency, measured_signal


def _record(kind: str | None = None) -> xr.Dataset:
    t = np.arange(1000) / 100.0
    ds = xr.Dataset({"torque": ("time", np.sin(t)), "torque_measured": ("time", np.cos(t))},
                    coords={"time": ("time", t, {"units": "s"})})
    if kind:
        ds.attrs["record_kind"] = kind
    return ds


def test_measured_signal_follows_the_record_kind():
    assert np.array_equal(measured_signal(_record(), "torque"), np.cos(_record().time))
    assert np.array_equal(measured_signal(_record("measured"), "torque"),
                          np.sin(_record().time))
    with pytest.raises(DataError, match="speed_measured.*torque"):
        measured_signal(_record(), "speed")


def test_mean_shaft_frequency_from_pulses():
    # 2 pulses per revolution at exactly 7.5 rev/s
    ds = _record().assign(pulse_time=("pulse", np.arange(150) / 15.0))
    ds.attrs["pulses_per_rev"] = 2
    assert mean_shaft_frequency(ds) == pytest.approx(7.5, rel=1e-12)


def test_longest_segment_cuts_time_and_pulses():
    ds = _record("measured")
    seg = np.r_[np.zeros(300, int), np.ones(600, int), np.full(100, 2)]
    ds = ds.assign_coords(segment=("time", seg))
    ds["pulse_time"] = ("pulse", np.arange(0.05, 10.0, 0.1), {"units": "s"})
    out = longest_segment(ds)
    assert out.sizes["time"] == 600 and "segment" not in out.coords
    assert out.time.values[0] == 0.0 and out.time.values[-1] == pytest.approx(5.99)
    assert np.allclose(out.torque.values, np.sin(np.arange(300, 900) / 100.0))
    # pulses inside [3.00, 8.99] s, shifted to the segment's start
    assert np.allclose(out.pulse_time.values, np.arange(3.05, 8.99, 0.1) - 3.0)
    assert out.attrs["segment_used"] == ("longest of 3 gap-free segments: 600 samples "
                                         "from 3 s")
    # a record that was never split is returned as it is
    whole = _record()
    xr.testing.assert_identical(longest_segment(whole), whole)
