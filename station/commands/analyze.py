"""``station analyze FILE``: Allan deviation, five-term fit and spec figures of a record."""

from __future__ import annotations

import argparse
import json
import sys

from analysis.fit import FIT_METHODS
from station.analyze import DEFAULT_METHOD, analyze_record, format_analysis
from station.record_files import UNIT_TO_DEG_S, read_record


def add_record_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments every command that reads a rate record shares."""
    parser.add_argument("file", help="rate record: CSV or CSV.gz (header row; optional time column)")
    parser.add_argument("--rate", type=float, default=None, metavar="HZ",
                        help="sample rate in Hz (required when the file has no time column)")
    parser.add_argument("--units", choices=sorted(UNIT_TO_DEG_S), default="deg/s",
                        help="unit of the rate columns (default deg/s)")
    parser.add_argument("--axis", default=None, help="analyze only this axis (column name)")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``analyze`` sub-command."""
    p = sub.add_parser("analyze", help="Allan deviation, noise-term fit and spec figures of a record",
                       description=__doc__)
    add_record_arguments(p)
    p.add_argument("--estimator", choices=("overlapping", "clusters"), default="overlapping")
    p.add_argument("--taus", choices=("log", "octave", "all"), default="log",
                   help="tau grid: log-spaced (default), octaves, or every m")
    p.add_argument("--method", choices=FIT_METHODS, default=DEFAULT_METHOD,
                   help=f"fit method (default {DEFAULT_METHOD})")
    p.add_argument("--terms", default="QNBKR", help="noise terms to fit, a subset of QNBKR")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Read the record, analyze every axis, print a table or JSON."""
    record = read_record(args.file, sample_rate_hz=args.rate, units=args.units)
    if args.axis is not None:
        record = record.select(args.axis)
    axes = analyze_record(record, estimator=args.estimator, taus=args.taus, method=args.method,
                          terms=args.terms)
    if args.json:
        json.dump({"file": str(args.file), "axes": [a.as_json() for a in axes]}, sys.stdout)
        sys.stdout.write("\n")
    else:
        print(f"{args.file}: {record.n_samples} samples at {record.sample_rate_hz:g} Hz, "
              f"{len(axes)} axis/axes")
        print(format_analysis(axes))
    return 0
