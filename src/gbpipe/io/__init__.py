"""Input and output of every stage: NetCDF with CF-1.11 metadata and provenance, CSV
tables, job logs, atomic writes.

Public API
----------
write, read
    The one NetCDF writer and reader (:mod:`gbpipe.io.netcdf`).
block_writer, BlockFile
    A NetCDF file of :func:`write`'s content filled block by block along time (long
    outputs; :mod:`gbpipe.io.blocks`).
write_csv
    CSV tables (:mod:`gbpipe.io.tables`).
setup_log
    Send gbpipe's log records to a job's log file (:mod:`gbpipe.io.runlog`).
atomic_path, clean_temporaries
    Atomic output files, and the clean-up of what killed jobs left (:mod:`gbpipe.io.atomic`).
config_sha256, file_sha256, source_files
    Provenance (:mod:`gbpipe.io.provenance`).
measured_signal, mean_shaft_frequency, longest_segment
    The record contract: the measured form of a signal, the tacho shaft's mean speed, the
    longest gap-free piece of a split bench record (:mod:`gbpipe.io.records`).
cf_units, TIME_DIM
    CF unit spelling and the on-disk dimension of relative time axes (:mod:`gbpipe.io.cf`).
MARGIN_DB, rounding_margin_db
    When a noisy series is stored as float32 (:mod:`gbpipe.io.storage`).
"""

from gbpipe.io.atomic import atomic_path, clean_temporaries
from gbpipe.io.blocks import BlockFile, block_writer
from gbpipe.io.cf import TIME_DIM, cf_units
from gbpipe.io.netcdf import read, write
from gbpipe.io.provenance import config_sha256, file_sha256, source_files
from gbpipe.io.records import longest_segment, mean_shaft_frequency, measured_signal
from gbpipe.io.runlog import setup_log
from gbpipe.io.storage import MARGIN_DB, rounding_margin_db
from gbpipe.io.tables import write_csv

__all__ = ["write", "read", "block_writer", "BlockFile", "write_csv", "setup_log",
           "atomic_path", "clean_temporaries", "config_sha256", "file_sha256",
           "source_files", "cf_units", "TIME_DIM", "measured_signal", "mean_shaft_frequency",
           "longest_segment", "MARGIN_DB", "rounding_margin_db"]
