"""Read one measured record: files and channels as the mapping says, checked, converted
to SI, aligned on the common clock and resampled onto the record's uniform grid.

The order of work puts every cheap check before the expensive ones: the mapping
(:func:`gbpipe.measured.spec.parse`), then every file's existence and header, every
channel's name, every unit, and only then the data.

Two ways through: into memory (the default, a :class:`xarray.Dataset`), or — with
``out`` — block by block into a NetCDF file (:mod:`gbpipe.measured.stream`), for records
too long to hold in memory.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from gbpipe.measured import checks, derived, layout, stream
from gbpipe.measured.channels import Channel
from gbpipe.measured.spec import RecordSpec, parse
from gbpipe.measured.timebase import Piece, overlap, resample, unroll
from gbpipe.measured.writer import open_record, write_dataset

__all__ = ["read"]


def read(spec: Mapping[str, Any], base_dir: str | Path = ".", *, name: str = "record",
         min_duration: float | None = None, out: str | os.PathLike | None = None,
         provenance: Mapping[str, Any] | None = None) -> xr.Dataset:
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
    out : path, optional
        Write the record to this NetCDF file, converted and resampled block by block in
        bounded memory (long records; see ``docs/measured.md``, "Long records"), and
        return the file opened lazily. The file is written atomically: a failure leaves
        no file (and an existing one untouched).
    provenance : mapping, optional
        With ``out``: keyword arguments of :func:`gbpipe.io.write` for the provenance
        it stores — ``stage`` (default ``"measured"``), ``config`` (its SHA-256 is
        stored), ``wildcards``, ``sources`` (added to the record's files), ``title``.

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
        ``source_files`` (JSON: path, bytes, sha256), ``signal_sources`` (JSON); with
        ``out``, also the provenance of :func:`gbpipe.io.write`.

    Raises
    ------
    gbpipe.errors.ConfigError
        For a mapping error, naming its key path.
    gbpipe.errors.DataError
        For a file, channel or data problem, naming file, channel, field and sample.
    """
    rec = parse(spec, name)
    base = Path(base_dir)
    if out is None:
        return _in_memory(rec, base, min_duration)
    if stream.streamable(rec):
        stream.write_record(rec, base, out, min_duration=min_duration,
                            provenance=provenance)
    else:  # documented: bridging time gaps inserts samples, done in memory
        write_dataset(_in_memory(rec, base, min_duration), out, provenance,
                      [base / f.path for f in rec.files.values()])
    return open_record(out)


def _in_memory(rec: RecordSpec, base: Path, min_duration: float | None) -> xr.Dataset:
    fs = rec.sample_rate
    raw = _read_channels(rec, base)
    shift, clock = layout.epochs(raw)
    units: dict[str, str] = {}
    notes: dict[str, list[str]] = {}
    converted = {sname: layout.to_pieces(rec, rec.signals[sname], ch, base, shift[sname], units,
                                         notes)
                 for sname, ch in raw.items()}
    unroll({layout.source_label(rec, rec.signals[n], base): p for n, p in converted.items()})
    start, _ = overlap({layout.source_label(rec, rec.signals[n], base): (p[0].t0, p[-1].end)
                        for n, p in converted.items()})
    segs = layout.grids({n: [(q.t0, q.end) for q in p] for n, p in converted.items()}, start, fs)
    n_total = sum(n for _, n in segs)
    checks.length(n_total, fs, f"record '{rec.name}'", min_duration)
    time = np.concatenate([(m0 + np.arange(n)) / fs for m0, n in segs])
    ds = xr.Dataset(coords={"time": layout.time_coord(time)})
    if rec.gaps == "split":
        seg = np.concatenate([np.full(n, k) for k, (_, n) in enumerate(segs)])
        ds = ds.assign_coords(segment=("time", seg, {
            "units": "1", "long_name": "gap-free segment number"}))
    pulses = {}
    for sname, plist in converted.items():
        sig = rec.signals[sname]
        if sig.quantity == "tacho":
            pulses[sname] = layout.pulse_times(rec, sig, plist, base, start, time[-1], fs)
            continue
        unit = "rad/s" if sig.quantity == "angle" else units[sname]
        ds[sname] = ("time", _on_grid(plist, segs, start, fs, sig.quantity == "angle"),
                     layout.variable_attrs(sig, unit, notes))
    ds = layout.add_tachos(ds, rec, pulses)
    ds.attrs.update(layout.record_attrs(rec, base, raw, start, clock, notes))
    return ds


def _read_channels(rec: RecordSpec, base: Path) -> dict[str, Channel]:
    """Open every file, check every channel name and unit, then read the channels."""
    with ExitStack() as stack:
        sources = layout.open_checked(rec, base, stack)
        for key, src in sources.items():
            src.prefetch([s.channel for s in rec.signals.values() if s.file == key])
        return {s.name: sources[s.file].read(s.channel) for s in rec.signals.values()}


def _on_grid(plist: list[Piece], segs: list[tuple[int, int]], start: float, fs: float,
             angle: bool) -> np.ndarray:
    """One channel resampled onto the record grid, segment by segment."""
    out = np.empty(sum(n for _, n in segs)) if len(segs) > 1 else None
    filled = 0
    windows = [(p.t0, p.end) for p in plist]
    for m0, n in segs:
        t_a = start + m0 / fs
        piece = plist[layout.piece_at(windows, t_a, n, fs)]
        if angle:
            piece = Piece(derived.speed_from_angle(piece.values, piece.dt, fs), piece.t0,
                          piece.dt)
        y = resample(piece, t_a, fs, n)
        if out is None:
            return y  # one segment: keep the (possibly view) result, no extra copy
        out[filled:filled + n] = y
        filled += n
    return out
