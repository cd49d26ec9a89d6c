"""Fit and hold-out data of bench records, one record or several repeats pooled.

A bench record has no validation record and no truth. Each record gets its own operating
point (its mean before the inputs' first excitation in the band) and its own hold-out
window (:mod:`gbpipe.identify.windows`); the fit uses the rest of every record, in
pieces. Several records of one test (``group:`` in ``measured:``) are pooled that way:
one nonparametric estimate from the averages of every piece (its bounds narrow as
1/sqrt(n)) and one multi-experiment subspace model (:mod:`gbpipe.sysid` takes lists of
records, each with its own initial state).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
import xarray as xr

from gbpipe.identify.prepare import ConditionedRecord, decimation_filter, version_signals
from gbpipe.identify.windows import (
    Holdout,
    band_energy,
    excitation_onset,
    fit_pieces,
    holdout_window,
)

__all__ = ["BenchSource", "bench_sources", "bench_data", "operating_point_settle"]


class BenchSource(NamedTuple):
    """One bench record conditioned for identification: ``rec`` (its signals), ``hold``
    (its hold-out window, in conditioned samples) and ``notes`` (how both were chosen)."""

    name: str
    rec: ConditionedRecord
    hold: Holdout
    notes: dict[str, str]


def operating_point_settle(record: xr.Dataset, removed: xr.Dataset | None,
                           inputs: Sequence[str], version: str, settle: float,
                           s: Mapping[str, Any]) -> tuple[float, str]:
    """Length of the stretch whose mean is the operating point [s], and why.

    The inputs' first excitation in the band (:func:`gbpipe.identify.windows.
    excitation_onset`) when it comes before ``settle`` (``campaign.settle``) and after
    10 samples; else ``settle``.
    """
    fs = float(record.attrs["sample_rate"])
    x = np.column_stack(version_signals(record, inputs, version, removed))
    onset = excitation_onset(x, fs, (s["frf"]["f_min"], s["frf"]["f_max"]),
                             float(s["nonparametric"]["segment"]))
    if 10 / fs <= onset < settle:
        return onset, (f"mean over the first {onset:.3g} s, before the inputs' first "
                       f"excitation in the band (campaign.settle {settle:g} s would include it)")
    return settle, f"mean over the first {settle:g} s (campaign.settle)"


def bench_sources(records: Sequence[xr.Dataset],
                  removed: Sequence[Mapping[str, xr.Dataset]], settle: float,
                  s: Mapping[str, Any],
                  windows: Sequence[tuple[float, float] | None]) -> list[BenchSource]:
    """Condition each bench record and choose its operating point and hold-out window.

    Parameters
    ----------
    records : sequence of xarray.Dataset
        Bench records (one, or the repeats of one test).
    removed : sequence of mapping str -> xarray.Dataset
        Per record, per harmonic-removal version, the record after that removal.
    settle : float
        ``campaign.settle`` [s]: the longest operating-point stretch.
    s : mapping
        The validated ``identify`` section.
    windows : sequence of (float, float) or None
        Per record, its ``measured.<record>.validation`` window [s], or None (chosen from
        the data).
    """
    fs_id, first = float(s["sample_rate"]), s["versions"][0]
    band = (s["frf"]["f_min"], s["frf"]["f_max"])
    ins = list(dict.fromkeys(n for p in s["pairings"] for n in p["inputs"]))
    out = []
    for record, rem, window in zip(records, removed, windows, strict=True):
        fs = float(record.attrs["sample_rate"])
        t_op, how = operating_point_settle(record, rem.get(first), ins, first, settle, s)
        rec = ConditionedRecord(record, rem, fs, t_op, fs_id, s["lowpass"])
        # conditioned sample k is record time offset + k / fs_id (the filter's start-up
        # is dropped by the decimation)
        offset = (len(decimation_filter(fs, fs_id, s["lowpass"])[0]) - 1) / fs
        user = None if window is None else (window[0] - offset, window[1] - offset)
        hold = holdout_window(band_energy(rec(ins, first), fs_id, band), s["holdout"],
                              s["holdout_power_min"], fs_id, user)
        name = str(record.attrs.get("record", record.attrs.get("test", "record")))
        out.append(BenchSource(name, rec, hold, {
            "operating_point": how,
            "validation_test": (
                f"held out: {hold.start / fs_id + offset:.2f}-{hold.stop / fs_id + offset:.2f}"
                f" s of the record ({100 * hold.power_share:.0f} % of the inputs' band power; "
                f"{hold.source})")}))
    return out


def bench_data(sources: Sequence[BenchSource], names: Sequence[str], version: str,
               min_len: int) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Fit pieces and hold-out windows of ``names`` (data ``version``) over every source.

    Returns
    -------
    fit : list of ndarray, shape (n_k, len(names))
        The parts of every record outside its hold-out window, at least ``min_len``
        samples each.
    held : list of ndarray
        Each record's hold-out window.
    """
    fit, held = [], []
    for src in sources:
        x = src.rec(names, version)
        fit += fit_pieces(x, src.hold, min_len)
        held.append(x[src.hold.start:src.hold.stop])
    return fit, held
