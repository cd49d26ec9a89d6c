"""Readers of bench file formats, one module per format, behind one small interface.

Every reader is a :class:`Source`: ``names()`` lists the channel addresses a mapping may
use, ``read(name)`` returns a :class:`gbpipe.measured.channels.Channel`, ``prefetch(names)``
lets a text format read several columns in one pass, ``close()`` releases the file.
Readers that can stream (TDMS, delimited text) also offer ``stream(name)``, the channel
as a :class:`gbpipe.measured.columns.StreamChannel` read block by block (and delimited
text ``spill(names)``, its one pass over the columns); :func:`open_streams` gives every
format that interface, wrapping the channels of the others, read into memory.
:func:`open_source` picks the reader from ``format:`` or the file suffix and refuses a
missing or empty file before any parsing.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

from gbpipe.errors import DataError
from gbpipe.measured.channels import Channel
from gbpipe.measured.columns import StreamChannel, from_channel
from gbpipe.measured.formats import delimited, mat, mdf, tdms, uff
from gbpipe.measured.spec import FileSpec

__all__ = ["Source", "open_source", "open_streams", "FORMATS",
           "STREAMED", "format_of"]

#: format name -> (reader class, file suffixes)
FORMATS = {
    "tdms": (tdms.TdmsSource, (".tdms",)),
    "uff": (uff.UffSource, (".uff", ".unv", ".uf")),
    "mat": (mat.MatSource, (".mat",)),
    "csv": (delimited.DelimitedSource, (".csv", ".tsv", ".txt")),
    "mdf": (mdf.MdfSource, (".mf4", ".mdf")),  # ".dat" is MDF3 or text: give format:
}


class Source(Protocol):
    """What every format reader offers."""

    def names(self) -> list[str]: ...

    def read(self, name: str) -> Channel: ...

    def prefetch(self, names: list[str]) -> None: ...

    def close(self) -> None: ...


#: formats whose readers stream (the others are read into memory, then wrapped)
STREAMED = ("tdms", "csv")


def open_streams(source: Source, names: list[str]) -> dict[str, StreamChannel]:
    """The channels ``names`` of an open source as :class:`StreamChannel` objects.

    Streaming readers read nothing yet (a text reader first spills the columns to disk in
    one pass); the others read each channel into memory and wrap it.
    """
    if hasattr(source, "stream"):
        if hasattr(source, "spill"):
            source.spill(names)
        return {n: source.stream(n) for n in names}
    source.prefetch(names)
    return {n: from_channel(source.read(n)) for n in names}


def format_of(path: str | Path, fmt: str | None = None) -> str:
    """Format name from ``fmt`` (``format:`` of the mapping) or the suffix of ``path``."""
    if fmt is not None:
        if fmt not in FORMATS:
            raise DataError(f"{path}: field 'format'",
                            f"unknown format {fmt!r}; known: {', '.join(FORMATS)}")
        return fmt
    suffix = Path(path).suffix.lower()
    for name, (_, suffixes) in FORMATS.items():
        if suffix in suffixes:
            return name
    raise DataError(f"{path}: field 'path'", f"cannot tell the format from the suffix "
                    f"{suffix!r}: give format: one of {', '.join(FORMATS)}")


def open_source(fspec: FileSpec, base_dir: str | Path = ".") -> Source:
    """Open the file of ``fspec`` (path relative to ``base_dir``) with its format's reader.

    Raises
    ------
    gbpipe.errors.DataError
        For a missing or empty file, an unknown format, or a file its reader rejects.
    """
    path = Path(base_dir) / fspec.path
    if not path.is_file():
        raise DataError(f"{path}: field 'path'", f"no such file (files.{fspec.key}); "
                        f"paths are relative to {Path(base_dir).resolve()}")
    if path.stat().st_size == 0:
        raise DataError(f"{path}", "the file is empty (0 bytes)")
    fmt = format_of(path, fspec.format)
    if fspec.interleaved is not None and fmt != "tdms":
        raise DataError(f"{path}: field 'interleaved'", f"interleaved columns are read from "
                        f"TDMS files; a {fmt} file stores columns itself (MAT: address a "
                        f"column of a 2-D array as name[:, k])")
    return FORMATS[fmt][0](path, fspec)
