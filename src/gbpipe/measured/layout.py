"""What the in-memory and the streaming record readers share: the cheap checks before
any data (files, channel names, units), the common clock, the record grid, the
variables' metadata and the record's attributes.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Mapping
from contextlib import ExitStack
from pathlib import Path

import numpy as np
import xarray as xr

from gbpipe.errors import DataError
from gbpipe.io import source_files
from gbpipe.measured import checks, derived
from gbpipe.measured.channels import Channel, find
from gbpipe.measured.formats import Source, open_source
from gbpipe.measured.quantities import to_si
from gbpipe.measured.spec import RecordSpec, SignalSpec
from gbpipe.measured.timebase import Piece, intersect, pieces

__all__ = ["TOL", "open_checked", "epochs", "conversion", "convert", "source_label",
           "long_name", "variable_attrs", "to_pieces", "time_of", "grids", "piece_at",
           "time_coord", "add_tachos", "pulse_times", "record_attrs"]

log = logging.getLogger(__name__)

#: grid tolerance [samples]: clock fits are exact to ~1e-9 sample
TOL = 1e-6

_LONG = {"value": "{name} (measured, {channel})",
         "setpoint": "{name} (set-point, {channel})", "angle": "{name}: speed from encoder "
         "angle {channel}", "tacho": "{name}: tachometer pulse time from {channel}"}


def source_label(rec: RecordSpec, sig: SignalSpec, base: Path) -> str:
    """``file: channel 'name'`` of a signal, for messages."""
    return f"{base / rec.files[sig.file].path}: channel '{sig.channel}'"


def long_name(sig: SignalSpec) -> str:
    """The ``long_name`` attribute of a signal's variable."""
    return _LONG[sig.quantity].format(name=sig.name, channel=sig.channel)


def variable_attrs(sig: SignalSpec, unit: str, notes: Mapping[str, list[str]]) -> dict:
    """Attributes of a signal's variable: ``units``, ``long_name``, the levels of its
    value checks (``checks``) and, if any, the warnings they gave (``check_warnings``)."""
    attrs = {"units": unit, "long_name": long_name(sig),
             "checks": ", ".join(f"{k}: {v}" for k, v in sig.checks.items())}
    if notes.get(sig.name):
        attrs["check_warnings"] = "; ".join(notes[sig.name])
    return attrs


def _is_angle(sig: SignalSpec) -> bool:
    """Whether the signal's values are an angle: ``quantity: angle``, or a tacho from a
    cumulative encoder angle (``tacho: angle``)."""
    return sig.quantity == "angle" or (sig.quantity == "tacho" and sig.tacho == "angle")


def _check_angle(sig: SignalSpec, si_unit: str, where: str) -> None:
    if _is_angle(sig) and si_unit != "rad":
        raise DataError(f"{where}: field 'unit'", f"an encoder angle (quantity: angle or "
                        f"tacho: angle) needs an angle unit (deg, rad, rev); got "
                        f"{sig.unit or si_unit!r}")


def open_checked(rec: RecordSpec, base: Path, stack: ExitStack) -> dict[str, Source]:
    """Open every file (closed by ``stack``), then check every channel name and every
    mapped unit, before any data is read."""
    sources = {}
    for key, fspec in rec.files.items():
        src = open_source(fspec, base)
        stack.callback(src.close)
        sources[key] = src
    for sig in rec.signals.values():
        find(sig.channel, sources[sig.file].names(), str(base / rec.files[sig.file].path))
        if sig.unit is not None and (sig.quantity != "tacho" or _is_angle(sig)):
            where = source_label(rec, sig, base)
            _check_angle(sig, to_si(sig.unit, where)[2], where)
    return sources


def epochs(channels: Mapping[str, object]) -> tuple[dict[str, float], str]:
    """Seconds to add to each channel's clock to put it on the common clock, and how the
    clocks were aligned (an attribute of the record). ``channels`` have an ``epoch``."""
    known = {k: c.epoch for k, c in channels.items() if c.epoch is not None}
    if known and len(known) == len(channels):
        ref = min(known.values())
        return ({k: float((e - ref) / np.timedelta64(1, "ns")) * 1e-9
                 for k, e in known.items()}, "absolute start times of the files")
    how = "relative: the files' own clocks are taken as one common clock"
    if known:
        # Some files know their absolute start, others only relative time: the relative
        # clocks cannot be placed on the absolute one, so all are taken as relative.
        lack = ", ".join(k for k in channels if k not in known)
        how += f" (absolute start times ignored: {lack} have none)"
        log.warning("record clocks: %s", how)
    return dict.fromkeys(channels, 0.0), how


def conversion(file_unit: str | None, sig: SignalSpec,
               where: str) -> tuple[list[tuple[float, float]], str]:
    """``(scale, offset)`` steps that take a channel to SI (the mapping's, then the
    unit's), and the SI unit; checks the unit."""
    unit = sig.unit if sig.unit is not None else file_unit
    if unit is None:
        raise DataError(f"{where}: field 'unit'", "neither the mapping nor the file gives "
                        "a unit: add unit: to the signal")
    factor, offset, si = to_si(unit, where)
    _check_angle(sig, si, where)
    return [(sig.scale, sig.offset), (factor, offset)], si


def convert(v: np.ndarray, steps: list[tuple[float, float]]) -> np.ndarray:
    """Apply :func:`conversion` steps to ``v`` in place (a second copy of a long record
    is what bounds the memory) and return it."""
    for mul, add in steps:
        if mul != 1.0:
            v *= mul
        if add != 0.0:
            v += add
    return v


def to_pieces(rec: RecordSpec, sig: SignalSpec, ch: Channel, base: Path, shift: float,
              units: dict[str, str], notes: dict[str, list[str]]) -> list[Piece]:
    """Checked, SI-converted, gap-handled pieces of one channel read into memory, on the
    common clock; the SI unit goes into ``units``, the check warnings into ``notes``."""
    where = source_label(rec, sig, base)
    if ch.values.size == 0:
        raise DataError(where, "the channel holds no samples")
    if sig.quantity == "tacho" and sig.tacho == "count":
        derived.whole_counts(ch.values, where)
    values = checks.finite(ch.values, where, rec.interpolate_upto)
    if sig.quantity != "tacho":
        found = checks.clipping(values, sig.range, flat_top=sig.checks["flat_top"] != "off")
        notes[sig.name] = checks.enforce(found, sig.checks, where, time_of(ch))
        steps, units[sig.name] = conversion(ch.unit, sig, where)
        values = convert(values, steps)
    elif sig.tacho == "angle":  # to rad; a counter is scaled in derived.pulse_times
        values = convert(values, conversion(ch.unit, sig, where)[0])
    time = ch.time if ch.time is None or shift == 0.0 else ch.time + shift
    return pieces(values, where, t0=None if ch.t0 is None else ch.t0 + shift, dt=ch.dt,
                  time=time, gaps=rec.gaps, interpolate_upto=rec.interpolate_upto)


def time_of(ch) -> Callable[[int], float]:
    """Sample index -> time [s] on the file's clock, of a channel (in memory or streamed:
    ``time`` an array or a column)."""
    if ch.time is None:
        return lambda k: ch.t0 + k * ch.dt
    if isinstance(ch.time, np.ndarray):
        return lambda k: float(ch.time[k])
    return lambda k: float(ch.time.read(k, k + 1)[0])


def grids(windows: Mapping[str, list[tuple[float, float]]], start: float,
          fs: float) -> list[tuple[int, int]]:
    """(first grid index, length) of each gap-free segment common to all channels, from
    each channel's ``(t0, end)`` windows [s]."""
    end = min(w[-1][1] for w in windows.values())
    segs = [(start, end)]
    for w in windows.values():
        segs = intersect(segs, list(w))
    out = []
    for a, b in segs:
        m0 = int(np.ceil((a - start) * fs - TOL))
        m1 = int(np.floor((b - start) * fs + TOL))
        if m1 >= m0:
            out.append((m0, m1 - m0 + 1))
    return out


def piece_at(windows: list[tuple[float, float]], t_a: float, n: int, fs: float) -> int:
    """Index of the window that holds the grid segment of ``n`` samples from ``t_a``."""
    return next(i for i, (t0, end) in enumerate(windows) if t0 - TOL / fs <= t_a
                and t_a + (n - 1) / fs <= end + TOL / fs)


def time_coord(values: np.ndarray) -> tuple[str, np.ndarray, dict[str, str]]:
    """The ``time`` coordinate of a record."""
    return ("time", values, {"units": "s", "long_name": "time from record start"})


def add_tachos(ds: xr.Dataset, rec: RecordSpec,
               pulses: Mapping[str, np.ndarray]) -> xr.Dataset:
    """Tacho pulse times [s from the record start] as variables on their own pulse
    dimension; a single tacho also as the dataset's ``pulse_time`` (simulated records)."""
    for sname, pt in pulses.items():
        sig = rec.signals[sname]
        dim = "pulse" if len(pulses) == 1 else f"{sname}_pulse"
        ds[sname] = (dim, pt, {"units": "s", "long_name": long_name(sig),
                               "pulses_per_rev": sig.pulses_per_rev})
    if len(pulses) == 1:
        sig = rec.signals[next(iter(pulses))]
        if sig.name != "pulse_time":
            ds["pulse_time"] = ("pulse", ds[sig.name].values, {
                "units": "s", "long_name": f"tachometer pulse time ({sig.name})"})
        ds.attrs["pulses_per_rev"] = int(sig.pulses_per_rev)
        ds = ds.assign_coords(pulse=("pulse", np.arange(ds.sizes["pulse"]), {
            "units": "1", "long_name": "tachometer pulse number"}))
    return ds


def pulse_times(rec: RecordSpec, sig: SignalSpec, plist: list[Piece], base: Path,
                start: float, duration: float, fs: float) -> np.ndarray:
    """Pulse times [s from the record start] of a tacho signal inside the record."""
    where = source_label(rec, sig, base)
    pt = np.concatenate([derived.pulse_times(p.values, p.t0, p.dt, sig, where)
                         for p in plist])
    return pt[(pt >= start) & (pt <= start + duration + TOL / fs)] - start


def record_attrs(rec: RecordSpec, base: Path, channels: Mapping[str, object], start: float,
                 clock: str, notes: Mapping[str, list[str]], *,
                 hash_files: bool = True) -> dict[str, object]:
    """The record's attributes (``docs/measured.md``, "The record"); ``notes`` are the
    check warnings per signal; ``hash_files=False`` leaves out ``source_files`` (for a
    writer that stores it itself: hashing a long record's files takes seconds)."""
    attrs: dict[str, object] = {}
    known = [c.epoch for c in channels.values() if c.epoch is not None]
    if known and len(known) == len(channels):
        attrs["record_start"] = str(min(known) + np.timedelta64(int(round(start * 1e9)),
                                                                "ns"))
    attrs.update({
        # record_kind tells the analysis this record holds what the bench logged (no clean
        # or `_measured` twins of a signal): gbpipe.harmonics.measured_signal
        "record_kind": "measured",
        "record": rec.name, "record_start_s": start, "clock_alignment": clock,
        "sample_rate": rec.sample_rate,
        "gaps": rec.gaps if rec.gaps != "interpolate" else
        f"interpolate_upto {rec.interpolate_upto}",
        "signal_sources": json.dumps({s.name: {"file": rec.files[s.file].path,
                                               "channel": s.channel, "quantity": s.quantity,
                                               "checks": dict(s.checks)}
                                      for s in rec.signals.values()}),
        "check_warnings": json.dumps({k: v for k, v in notes.items() if v}),
    })
    if hash_files:
        attrs["source_files"] = json.dumps(source_files(base / f.path
                                                        for f in rec.files.values()))
    return attrs
