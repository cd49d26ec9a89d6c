"""Read one measured record: files and channels as the mapping says, checked, converted
to SI, aligned on the common clock and resampled onto the record's uniform grid.

The order of work puts every cheap check before the expensive ones: the mapping
(:func:`gbpipe.measured.spec.parse`), then every file's existence and header, every
channel's name, every unit, and only then the data.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.errors import DataError
from gbpipe.io import source_files
from gbpipe.measured import checks, derived
from gbpipe.measured.channels import Channel, find
from gbpipe.measured.formats import open_source
from gbpipe.measured.quantities import to_si
from gbpipe.measured.spec import RecordSpec, SignalSpec, parse
from gbpipe.measured.timebase import Piece, intersect, overlap, pieces, resample

__all__ = ["read"]

log = logging.getLogger(__name__)

#: grid tolerance [samples]: clock fits are exact to ~1e-9 sample
_TOL = 1e-6

_LONG = {"value": "{name} (measured, {channel})", "angle": "{name}: speed from encoder "
         "angle {channel}", "tacho": "{name}: tachometer pulse time from {channel}"}


def _epochs(channels: dict[str, Channel]) -> tuple[dict[str, float], str]:
    """Seconds to add to each channel's clock to put it on the common clock, and how the
    clocks were aligned (an attribute of the record)."""
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


def _convert(ch: Channel, sig: SignalSpec, where: str) -> tuple[np.ndarray, str]:
    """Values in SI (scale and offset of the mapping first, then the unit), computed in
    place: the reader's array is this function's to change, and a second copy of a long
    record is what bounds the memory."""
    unit = sig.unit if sig.unit is not None else ch.unit
    if unit is None:
        raise DataError(f"{where}: field 'unit'", "neither the mapping nor the file gives "
                        "a unit: add unit: to the signal")
    factor, offset, si = to_si(unit, where)
    v = ch.values
    for mul, add in ((sig.scale, sig.offset), (factor, offset)):
        if mul != 1.0:
            v *= mul
        if add != 0.0:
            v += add
    return v, si


def _source_label(rec: RecordSpec, sig: SignalSpec, base: Path) -> str:
    return f"{base / rec.files[sig.file].path}: channel '{sig.channel}'"


def read(spec: Mapping[str, Any], base_dir: str | Path = ".", *, name: str = "record",
         min_duration: float | None = None) -> xr.Dataset:
    """Read one entry of the config's ``measured:`` mapping into a record Dataset.

    Parameters
    ----------
    spec : mapping
        ``files``, ``sample_rate``, ``signals``, ``gaps`` (see ``docs/measured.md``).
    base_dir : path
        Folder the file paths are relative to.
    name : str
        Record name (error messages, the ``record`` attribute).
    min_duration : float, optional
        Shortest acceptable record [s] (e.g. the TSA cycles or identification horizons
        the analysis needs).

    Returns
    -------
    xarray.Dataset
        Variables named as in ``signals`` on ``time`` [s from the record start], in SI
        units; ``quantity: tacho`` signals as ``pulse_time`` arrays on their own pulse
        dimension (``<name>`` with attribute ``pulses_per_rev``; a single tacho is also
        the dataset's ``pulse_time``/``pulses_per_rev`` as in simulated records). With
        ``gaps: split``, a ``segment`` coordinate numbers the gap-free pieces and the
        time axis skips the gaps. Attributes: ``record_start`` (absolute, ISO 8601, when
        the files know it), ``record_start_s`` (on the common clock), ``sample_rate``,
        ``source_files`` (JSON: path, bytes, sha256), ``signal_sources`` (JSON).

    Raises
    ------
    gbpipe.errors.ConfigError
        For a mapping error, naming its key path.
    gbpipe.errors.DataError
        For a file, channel or data problem, naming file, channel, field and sample.
    """
    rec = parse(spec, name)
    base = Path(base_dir)
    fs = rec.sample_rate
    raw = _read_channels(rec, base)
    shift, clock = _epochs(raw)
    units: dict[str, str] = {}
    converted = {sname: _to_pieces(rec, rec.signals[sname], ch, base, shift[sname], units)
                 for sname, ch in raw.items()}
    start, _ = overlap({_source_label(rec, rec.signals[n], base): (p[0].t0, p[-1].end)
                        for n, p in converted.items()})
    grids = _grids(converted, start, fs)
    n_total = sum(n for _, n in grids)
    checks.length(n_total, fs, f"record '{name}'", min_duration)
    time = np.concatenate([(m0 + np.arange(n)) / fs for m0, n in grids])
    ds = xr.Dataset(coords={"time": ("time", time, {
        "units": "s", "long_name": "time from record start"})})
    if rec.gaps == "split":
        seg = np.concatenate([np.full(n, k) for k, (_, n) in enumerate(grids)])
        ds = ds.assign_coords(segment=("time", seg, {
            "units": "1", "long_name": "gap-free segment number"}))
    tachos = [s for s in rec.signals.values() if s.quantity == "tacho"]
    for sname, plist in converted.items():
        sig = rec.signals[sname]
        where = _source_label(rec, sig, base)
        long_name = _LONG[sig.quantity].format(name=sname, channel=sig.channel)
        if sig.quantity == "tacho":
            pt = np.concatenate([derived.pulse_times(p.values, p.t0, p.dt, sig, where)
                                 for p in plist])
            pt = pt[(pt >= start) & (pt <= start + time[-1] + _TOL / fs)] - start
            dim = "pulse" if len(tachos) == 1 else f"{sname}_pulse"
            ds[sname] = (dim, pt, {"units": "s", "long_name": long_name,
                                   "pulses_per_rev": sig.pulses_per_rev})
            continue
        unit = "rad/s" if sig.quantity == "angle" else units[sname]
        ds[sname] = ("time", _on_grid(plist, grids, start, fs, sig.quantity == "angle"),
                     {"units": unit, "long_name": long_name})
    if len(tachos) == 1:
        sig = tachos[0]
        if sig.name != "pulse_time":
            ds["pulse_time"] = ("pulse", ds[sig.name].values, {
                "units": "s", "long_name": f"tachometer pulse time ({sig.name})"})
        ds.attrs["pulses_per_rev"] = int(sig.pulses_per_rev)
        ds = ds.assign_coords(pulse=("pulse", np.arange(ds.sizes["pulse"]), {
            "units": "1", "long_name": "tachometer pulse number"}))
    epochs = [c.epoch for c in raw.values() if c.epoch is not None]
    if epochs and len(epochs) == len(raw):
        ds.attrs["record_start"] = str(min(epochs) + np.timedelta64(int(round(start * 1e9)),
                                                                      "ns"))
    ds.attrs.update({
        "record": name, "record_start_s": start, "clock_alignment": clock, "sample_rate": fs,
        "gaps": rec.gaps if rec.gaps != "interpolate" else
        f"interpolate_upto {rec.interpolate_upto}",
        "source_files": json.dumps(source_files(base / f.path for f in rec.files.values())),
        "signal_sources": json.dumps({s.name: {"file": rec.files[s.file].path,
                                               "channel": s.channel, "quantity": s.quantity}
                                      for s in rec.signals.values()}),
    })
    return ds


def _read_channels(rec: RecordSpec, base: Path) -> dict[str, Channel]:
    """Open every file, check every channel name and unit, then read the channels."""
    with ExitStack() as stack:
        sources = {}
        for key, fspec in rec.files.items():
            src = open_source(fspec, base)
            stack.callback(src.close)
            sources[key] = src
        for sig in rec.signals.values():  # every name and unit before any data
            find(sig.channel, sources[sig.file].names(), str(base / rec.files[sig.file].path))
            if sig.unit is not None and sig.quantity != "tacho":
                where = _source_label(rec, sig, base)
                _check_angle(sig, to_si(sig.unit, where)[2], where)
        for key, src in sources.items():
            src.prefetch([s.channel for s in rec.signals.values() if s.file == key])
        return {s.name: sources[s.file].read(s.channel) for s in rec.signals.values()}


def _check_angle(sig: SignalSpec, si_unit: str, where: str) -> None:
    if sig.quantity == "angle" and si_unit != "rad":
        raise DataError(f"{where}: field 'unit'", f"quantity: angle needs an angle unit "
                        f"(deg, rad, rev); got {sig.unit or si_unit!r}")


def _to_pieces(rec: RecordSpec, sig: SignalSpec, ch: Channel, base: Path, shift: float,
               units: dict[str, str]) -> list[Piece]:
    """Checked, SI-converted, gap-handled pieces of one channel on the common clock."""
    where = _source_label(rec, sig, base)
    if ch.values.size == 0:
        raise DataError(where, "the channel holds no samples")
    values = checks.finite(ch.values, where, rec.interpolate_upto)
    if sig.quantity != "tacho":
        # An encoder angle legitimately stays at its maximum when the shaft stops:
        # only the converter range can tell it clipped.
        checks.clipping(values, where, sig.range, flat_top=sig.quantity != "angle")
        values, units[sig.name] = _convert(Channel(values, ch.unit), sig, where)
        _check_angle(sig, units[sig.name], where)
    time = ch.time if ch.time is None or shift == 0.0 else ch.time + shift
    return pieces(values, where, t0=None if ch.t0 is None else ch.t0 + shift, dt=ch.dt,
                  time=time, gaps=rec.gaps, interpolate_upto=rec.interpolate_upto)


def _grids(converted: dict[str, list[Piece]], start: float,
           fs: float) -> list[tuple[int, int]]:
    """(first grid index, length) of each gap-free segment common to all channels."""
    end = min(p[-1].end for p in converted.values())
    segs = [(start, end)]
    for plist in converted.values():
        segs = intersect(segs, [(q.t0, q.end) for q in plist])
    grids = []
    for a, b in segs:
        m0 = int(np.ceil((a - start) * fs - _TOL))
        m1 = int(np.floor((b - start) * fs + _TOL))
        if m1 >= m0:
            grids.append((m0, m1 - m0 + 1))
    return grids


def _on_grid(plist: list[Piece], grids: list[tuple[int, int]], start: float, fs: float,
             angle: bool) -> np.ndarray:
    """One channel resampled onto the record grid, segment by segment."""
    out = np.empty(sum(n for _, n in grids)) if len(grids) > 1 else None
    filled = 0
    for m0, n in grids:
        t_a = start + m0 / fs
        piece = next(p for p in plist if p.t0 - _TOL / fs <= t_a
                     and t_a + (n - 1) / fs <= p.end + _TOL / fs)
        if angle:
            piece = Piece(derived.speed_from_angle(piece.values, piece.dt, fs), piece.t0,
                          piece.dt)
        y = resample(piece, t_a, fs, n)
        if out is None:
            return y  # one segment: keep the (possibly view) result, no extra copy
        out[filled:filled + n] = y
        filled += n
    return out
