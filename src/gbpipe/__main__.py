"""Command line: ``python -m gbpipe inspect FILE [--format F] [--time CH] [--sample-rate HZ]``
prints every channel of a bench file (name, length, time base, unit, min/max, NaN count),
the first step of writing a ``measured:`` mapping (docs/measured.md)."""

from __future__ import annotations

import argparse
import sys

from gbpipe.errors import GbpipeError
from gbpipe.measured import format_listing, list_channels


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    parser = argparse.ArgumentParser(prog="python -m gbpipe")
    sub = parser.add_subparsers(dest="command", required=True)
    ins = sub.add_parser("inspect", help="list every channel of a bench file")
    ins.add_argument("file")
    ins.add_argument("--format", help="tdms, uff, mat, csv or mdf (default: from suffix)")
    ins.add_argument("--time", help="time channel, for formats without a time base")
    ins.add_argument("--sample-rate", type=float, help="sample rate [Hz] of plain arrays")
    args = parser.parse_args(argv)
    try:
        rows = list_channels(args.file, args.format, time=args.time,
                             sample_rate=args.sample_rate)
    except GbpipeError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(format_listing(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
