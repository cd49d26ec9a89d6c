"""The record contract's accessors shared by every stage that reads a record.

A simulated record carries each signal clean (``name``) and measured-like
(``<name>_measured``); a bench record (``record_kind = "measured"``, written by
:func:`gbpipe.measured.read`) carries only what the bench logged, under ``name``. Harmonic
removal and identification both read "the measured form of a signal" through
:func:`measured_signal`, so either runs unchanged on both kinds (docs/architecture.md,
"Data contract").
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from gbpipe.errors import DataError
from gbpipe.units import TWO_PI

__all__ = ["measured_signal", "mean_shaft_frequency", "longest_segment"]


def measured_signal(record: xr.Dataset, name: str) -> xr.DataArray:
    """The measured(-like) form of signal ``name`` in a record.

    A simulated record carries each signal clean (``name``) and measured-like
    (``<name>_measured``: harmonics and sensor noise); a measured record
    (``record_kind = "measured"``, :func:`gbpipe.measured.read`) carries only what the bench
    logged, under ``name``.

    Raises
    ------
    gbpipe.errors.DataError
        The record has no such signal.
    """
    key = name if record.attrs.get("record_kind") == "measured" else f"{name}_measured"
    if key not in record:
        have = [str(v) for v in record.data_vars if record[v].dims == ("time",)]
        raise DataError(key, f"is not in the record (it holds {', '.join(have)}); "
                        "identify.pairings may only name recorded signals")
    return record[key]


def mean_shaft_frequency(record: xr.Dataset) -> float:
    """Mean rotation frequency of the tachometer shaft (the GB1 HSS) over the record [Hz]:
    from its recorded speed when there is one, else from the pulse count."""
    if "speed_gb1_hss" in record:
        return float(np.mean(record["speed_gb1_hss"].values)) / TWO_PI
    p = np.asarray(record["pulse_time"].values, dtype=float)
    return (p.size - 1) / int(record.attrs["pulses_per_rev"]) / float(p[-1] - p[0])


def longest_segment(record: xr.Dataset) -> xr.Dataset:
    """The longest gap-free piece of a record read with ``gaps: split`` (else the record).

    Averaging and identification assume one continuous time axis: across a gap the shaft
    angle and the model state jump. A split record is therefore analysed on its longest
    segment, with its pulses and time axis restarted at the segment's first sample.
    """
    if "segment" not in record.coords:
        return record
    seg = record["segment"].values
    counts = np.bincount(seg.astype(int))
    keep = seg == int(np.argmax(counts))
    out = record.isel(time=keep)
    t0, t1 = float(out.time.values[0]), float(out.time.values[-1])
    out = out.drop_vars("segment").assign_coords(
        time=("time", out.time.values - t0, dict(record.time.attrs)))
    if "pulse_time" in out:
        p = out["pulse_time"].values
        out = out.isel(pulse=(p >= t0) & (p <= t1))
        for name in [v for v in out.data_vars if out[v].dims == ("pulse",)]:
            out[name] = (out[name] - t0).assign_attrs(record[name].attrs)
    out.attrs["segment_used"] = (f"longest of {counts.size} gap-free segments: "
                                 f"{int(keep.sum())} samples from {t0:g} s")
    return out
