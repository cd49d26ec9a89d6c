"""Command line.

``python -m gbpipe inspect FILE [--format F] [--time CH] [--sample-rate HZ]`` prints every
channel of a bench file (name, length, time base, unit, min/max, NaN count), the first
step of writing a ``measured:`` mapping (docs/measured.md).

``python -m gbpipe export-opentorsion CONFIG [OVERLAY ...] -o OUT.json|OUT.py`` writes the
config's ``drivetrain:`` (the overlays, e.g. a fit's ``results/fit/<record>.yaml``, merged
on top as ``--configfile`` does) as an openTorsion model: TORS JSON or a Python model file
(docs/opentorsion.md, "Export").
"""

from __future__ import annotations

import argparse
import sys

from gbpipe.config import load
from gbpipe.errors import ConfigError, GbpipeError
from gbpipe.measured import format_listing, list_channels
from gbpipe.model.opentorsion_io import export


def _inspect(args: argparse.Namespace) -> None:
    print(format_listing(list_channels(args.file, args.format, time=args.time,
                                       sample_rate=args.sample_rate)))


def _export(args: argparse.Namespace) -> None:
    cfg = load(args.config, *args.overlays)
    if not cfg.get("drivetrain"):
        raise ConfigError("drivetrain", f"{args.config} describes no drivetrain: section "
                          "(the paper's bench has planetary stages, which openTorsion 0.3 "
                          "cannot hold); export a config with a drivetrain")
    export(cfg["drivetrain"], args.output)
    print(f"wrote {args.output}")


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    parser = argparse.ArgumentParser(prog="python -m gbpipe")
    sub = parser.add_subparsers(dest="command", required=True)
    ins = sub.add_parser("inspect", help="list every channel of a bench file")
    ins.add_argument("file")
    ins.add_argument("--format", help="tdms, uff, mat, csv or mdf (default: from suffix)")
    ins.add_argument("--time", help="time channel, for formats without a time base")
    ins.add_argument("--sample-rate", type=float, help="sample rate [Hz] of plain arrays")
    ins.set_defaults(run=_inspect)
    exp = sub.add_parser("export-opentorsion",
                         help="write the config's drivetrain as an openTorsion model")
    exp.add_argument("config", help="the config (YAML) with a drivetrain: section")
    exp.add_argument("overlays", nargs="*",
                     help="overlays merged on top in order, e.g. results/fit/<record>.yaml")
    exp.add_argument("-o", "--output", required=True,
                     help="out.json (openTorsion TORS) or out.py (Python model file)")
    exp.set_defaults(run=_export)
    args = parser.parse_args(argv)
    try:
        args.run(args)
    except (GbpipeError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
