"""A measured record read, checked, converted and resampled block by block into a
NetCDF file: long records in bounded memory, with the values of the in-memory reader.

Each channel is a :class:`gbpipe.measured.columns.Column` (TDMS: read from the file in
blocks; delimited text: spilled to disk in one chunked pass; the other formats: read into
memory and wrapped). The checks run block by block (:func:`gbpipe.measured.checks.scan`,
:func:`gbpipe.measured.timebase.scan_clock`) and name the absolute sample index; every
output block is computed from just the input samples its filters need
(:class:`gbpipe.measured.resample.BlockResampler`) and written straight into the file
(:func:`gbpipe.measured.writer.write_blocks`). Memory: a few blocks of
:data:`OUT_BLOCK` samples, whatever the record's length. Tacho channels are read whole
(their pulse times are computed as in memory).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from scipy.signal import savgol_filter

from gbpipe.errors import DataError
from gbpipe.io import BlockFile
from gbpipe.measured import checks, derived, layout
from gbpipe.measured.channels import Channel
from gbpipe.measured.columns import Column, StreamChannel, blocks
from gbpipe.measured.formats import STREAMED, format_of, open_streams
from gbpipe.measured.resample import BlockResampler
from gbpipe.measured.spec import RecordSpec, SignalSpec
from gbpipe.measured.timebase import overlap, scan_clock, unroll
from gbpipe.measured.writer import write_blocks
from gbpipe.progress import Progress

__all__ = ["streamable", "write_record", "StreamPiece", "OUT_BLOCK"]

log = logging.getLogger(__name__)

#: record samples computed and written at a time, per variable (8 MB of float64)
OUT_BLOCK = 1 << 20


@dataclass
class StreamPiece:
    """A gap-free run ``[first, stop)`` of a checked column, sample ``first + k`` at
    ``t0 + k dt`` [s] on the common clock, taken to SI by ``steps``."""

    column: Column
    first: int
    stop: int
    t0: float
    dt: float
    steps: list[tuple[float, float]]
    era: int = 0

    @property
    def size(self) -> int:
        return self.stop - self.first

    @property
    def end(self) -> float:
        """Time of the last sample [s]."""
        return self.t0 + (self.size - 1) * self.dt

    def read(self, i: int, j: int) -> np.ndarray:
        """Samples ``i … j-1`` of the piece, in SI."""
        return layout.convert(self.column.read(self.first + i, self.first + j), self.steps)


def streamable(rec: RecordSpec) -> bool:
    """Whether :func:`write_record` can read ``rec``: all but bridging time gaps
    (``gaps: {interpolate_upto: N}`` with sample times from a file), which inserts
    samples and is done in memory."""
    if rec.gaps != "interpolate":
        return True
    try:
        return all(f.time is None and format_of(f.path, f.format) in STREAMED
                   for f in rec.files.values())
    except DataError:
        return True  # an unknown format: the streaming reader's checks say it properly


def _speed_reader(piece: StreamPiece, fs: float):
    """Block reader of the speed [rad/s] of an angle piece, as
    :func:`gbpipe.measured.derived.speed_from_angle` gives it on the whole piece: the
    Savitzky–Golay filter is local, so a block needs half a window of context."""
    n = derived.savgol_window(1.0 / piece.dt, fs)
    if piece.size < n:
        n = piece.size - (1 - piece.size % 2)

    def read(i: int, j: int) -> np.ndarray:
        lo = max(i - n, 0)
        hi = min(max(j + n, lo + n), piece.size)
        lo = max(min(lo, hi - n), 0)
        speed = savgol_filter(piece.read(lo, hi), n, derived.POLYORDER, deriv=1,
                              delta=piece.dt, mode="interp")
        return speed[i - lo:j - lo]

    return read


def _pieces(rec: RecordSpec, sig: SignalSpec, ch: StreamChannel, where: str, shift: float,
            units: dict[str, str], notes: dict[str, list[str]]) -> list[StreamPiece]:
    """Checked gap-free pieces of a streamed channel (the twin of
    :func:`gbpipe.measured.layout.to_pieces`)."""
    if ch.values.size == 0:
        raise DataError(where, "the channel holds no samples")
    column, found = checks.scan(ch.values, where, rec.interpolate_upto, sig.range,
                                flat_top=sig.checks["flat_top"] != "off")
    notes[sig.name] = checks.enforce(found, sig.checks, where, layout.time_of(ch))
    steps, units[sig.name] = layout.conversion(ch.unit, sig, where)
    if ch.time is None:
        runs = [(0, ch.values.size, ch.t0 + shift, ch.dt, 0)]
    else:
        runs = scan_clock(ch.time, where, shift=shift, gaps=rec.gaps)
    return [StreamPiece(column, a, b, t0, dt, steps, era) for a, b, t0, dt, era in runs]


def _whole(ch: StreamChannel) -> Channel:
    """A streamed channel read into memory (tachometers)."""
    return Channel(ch.values.read(0, ch.values.size), ch.unit, ch.t0, ch.dt,
                   None if ch.time is None else ch.time.read(0, ch.time.size), ch.epoch)


def _open(rec: RecordSpec, base: Path, stack: ExitStack) -> dict[str, StreamChannel]:
    """Every signal's channel for block-wise reading, in the mapping's order, after the
    cheap checks (files, channel names, units)."""
    sources = layout.open_checked(rec, base, stack)
    chans: dict[str, StreamChannel] = {}
    for key, src in sources.items():
        sigs = [s for s in rec.signals.values() if s.file == key]
        opened = open_streams(src, [s.channel for s in sigs])
        chans.update({s.name: opened[s.channel] for s in sigs})
    return {s: chans[s] for s in rec.signals}


def write_record(rec: RecordSpec, base: Path, out: str | os.PathLike, *,
                 min_duration: float | None = None,
                 provenance: Mapping[str, Any] | None = None) -> Path:
    """Read the record ``rec`` block by block into the NetCDF file ``out``.

    The same checks, values and attributes as the in-memory reader
    (:func:`gbpipe.measured.read` without ``out``), plus the provenance of
    :func:`gbpipe.io.write`; written atomically.
    """
    fs = rec.sample_rate
    with ExitStack() as stack:
        chans = _open(rec, base, stack)
        shift, clock = layout.epochs(chans)
        units: dict[str, str] = {}
        notes: dict[str, list[str]] = {}
        plan, tachos = {}, {}
        for sname, ch in chans.items():
            sig = rec.signals[sname]
            if sig.quantity == "tacho":
                tachos[sname] = layout.to_pieces(rec, sig, _whole(ch), base, shift[sname], units,
                                                 notes)
            else:
                plan[sname] = _pieces(rec, sig, ch, layout.source_label(rec, sig, base),
                                      shift[sname], units, notes)
        unroll({layout.source_label(rec, rec.signals[n], base): plist
                for n, plist in {**plan, **tachos}.items()})
        windows = {n: [(p.t0, p.end) for p in plist]
                   for n, plist in {**plan, **tachos}.items()}
        windows = {n: windows[n] for n in rec.signals}
        start, _ = overlap({layout.source_label(rec, rec.signals[n], base): (w[0][0], w[-1][1])
                            for n, w in windows.items()})
        segs = layout.grids(windows, start, fs)
        n_total = sum(n for _, n in segs)
        checks.length(n_total, fs, f"record '{rec.name}'", min_duration)
        duration = (segs[-1][0] + segs[-1][1] - 1) / fs
        pulses = {n: layout.pulse_times(rec, rec.signals[n], plist, base, start, duration, fs)
                  for n, plist in tachos.items()}
        template = _template(rec, plan, units, notes, pulses)
        template.attrs.update(layout.record_attrs(rec, base, chans, start, clock, notes,
                                                  hash_files=False))

        def fill(f: BlockFile) -> None:
            _fill(f, rec, plan, segs, start)

        return write_blocks(template, n_total, out, fill, provenance,
                            [base / f.path for f in rec.files.values()])


def _template(rec: RecordSpec, plan: Mapping[str, list[StreamPiece]],
              units: Mapping[str, str], notes: Mapping[str, list[str]],
              pulses: Mapping[str, np.ndarray]) -> xr.Dataset:
    """The record with a two-sample time axis: every variable and its metadata."""
    ds = xr.Dataset(coords={"time": layout.time_coord(np.arange(2) / rec.sample_rate)})
    if rec.gaps == "split":
        ds = ds.assign_coords(segment=("time", np.zeros(2, dtype=np.int64), {
            "units": "1", "long_name": "gap-free segment number"}))
    for sname in plan:
        sig = rec.signals[sname]
        unit = "rad/s" if sig.quantity == "angle" else units[sname]
        ds[sname] = ("time", np.zeros(2), layout.variable_attrs(sig, unit, notes))
    return layout.add_tachos(ds, rec, pulses)


def _fill(f: BlockFile, rec: RecordSpec, plan: Mapping[str, list[StreamPiece]],
          segs: list[tuple[int, int]], start: float) -> None:
    """Write the time axis (and segment numbers) and every signal, block by block."""
    fs = rec.sample_rate
    filled = 0
    for k, (m0, n) in enumerate(segs):
        for a, b in blocks(n, OUT_BLOCK):
            f.write("time", filled + a, (m0 + np.arange(a, b)) / fs)
            if "segment" in f:
                f.write("segment", filled + a, np.full(b - a, k))
        filled += n
    progress = Progress(log, f"record '{rec.name}': signals written", len(plan))
    for done, (sname, plist) in enumerate(plan.items()):
        angle = rec.signals[sname].quantity == "angle"
        filled = 0
        windows = [(p.t0, p.end) for p in plist]
        for m0, n in segs:
            t_a = start + m0 / fs
            piece = plist[layout.piece_at(windows, t_a, n, fs)]
            read = _speed_reader(piece, fs) if angle else piece.read
            values = BlockResampler(read, piece.size, piece.t0, piece.dt, t_a, fs, n)
            for a, b in blocks(n, OUT_BLOCK):
                f.write(sname, filled + a, values(a, b))
                progress(done, f"{sname}: {filled + b} samples")
            filled += n
