"""Measured bench records in: TDMS, UFF 58, MAT, CSV/TSV and MDF4 files, mapped by the
config's ``measured:`` section onto the signal names the analysis uses.

Public API
----------
read
    One entry of ``measured:`` -> a record :class:`xarray.Dataset` with the data
    contract of a simulated record (:mod:`gbpipe.measured.record`).
list_channels, format_listing
    Every channel of a file: name, length, time base, unit, min/max, NaN count
    (:mod:`gbpipe.measured.inspect`; ``python -m gbpipe inspect FILE``).
parse
    Check a ``measured:`` entry without reading data (:mod:`gbpipe.measured.spec`).

The format, the checks and an example: ``docs/measured.md``.
"""

from gbpipe.measured.inspect import format_listing, list_channels
from gbpipe.measured.record import read
from gbpipe.measured.spec import RecordSpec, SignalSpec, parse

__all__ = ["read", "list_channels", "format_listing", "parse", "RecordSpec", "SignalSpec"]
