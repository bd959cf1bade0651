"""``station analyze FILE``: Allan deviation, five-term fit and spec figures of a record."""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING

from analysis.deviations import DEVIATION_KINDS
from analysis.fit import FIT_METHODS
from station.evaluation.analyze import DEFAULT_METHOD, OUTLIER_POLICIES, format_analysis
from station.evaluation.settings import TAU_GRIDS
from station.storage.csv_records import UNIT_TO_DEG_S

if TYPE_CHECKING:
    from station.services.records import RecordSource


def add_record_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments every command that reads a rate record shares."""
    parser.add_argument("file", help="rate record: CSV or CSV.gz (header row; optional time "
                                     "column), or a run file (.h5) from station record")
    parser.add_argument("--rate", type=float, default=None, metavar="HZ",
                        help="sample rate in Hz (required when the file has no time column)")
    parser.add_argument("--units", choices=sorted(UNIT_TO_DEG_S), default="deg/s",
                        help="unit of the rate columns (default deg/s)")
    parser.add_argument("--axis", default=None, help="analyze only this axis (column name)")
    parser.add_argument("--unit", default=None,
                        help="run files: the unit (unit1, unit2, ... or its serial number; "
                             "default the first)")
    parser.add_argument("--start-s", type=float, default=0.0, metavar="S",
                        help="analyze from S seconds after the record start (default 0)")
    parser.add_argument("--stop-s", type=float, default=None, metavar="S",
                        help="analyze up to S seconds after the record start (default: end)")
    parser.add_argument("--profile", default=None,
                        help="product profile whose warm-up (warmup_s) is discarded; run "
                             "files default to the profile they were recorded with")
    parser.add_argument("--warmup-s", type=float, default=None, metavar="S",
                        help="warm-up to discard from the start, s (overrides the profile)")


def record_source(args: argparse.Namespace) -> RecordSource:
    """The :class:`RecordSource` the shared record arguments name."""
    from station.services.records import RecordSource

    return RecordSource(args.file, rate_hz=args.rate, units=args.units, axis=args.axis,
                        unit=args.unit, start_s=args.start_s, stop_s=args.stop_s,
                        profile=args.profile, warmup_s=args.warmup_s)


def print_notes(command: str, notes: tuple[str, ...]) -> None:
    """A workflow's notes for the operator, on stderr (``station COMMAND: note: ...``)."""
    for note in notes:
        print(f"station {command}: note: {note}", file=sys.stderr)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``analyze`` sub-command."""
    p = sub.add_parser("analyze", help="Allan deviation, noise-term fit and spec figures of a record",
                       description=__doc__)
    add_record_arguments(p)
    p.add_argument("--estimator", choices=("overlapping", "clusters"), default=None,
                   help="Allan variance the fit and figures use (default overlapping; clusters "
                        "with --deviation adev)")
    p.add_argument("--deviation", choices=DEVIATION_KINDS, default=None,
                   help="deviation shown and listed (JSON tau_s/adev/adev_ci_*): oadev, adev (clusters), "
                        "mdev, hdev, ohdev, tdev (an angle), totdev, theo1; default the estimator's "
                        "Allan deviation. The fit and figures stay on the Allan variance")
    p.add_argument("--taus", choices=TAU_GRIDS, default="log",
                   help="tau grid: log-spaced to the longest tau with two clusters (default), "
                        "octaves, or every m")
    p.add_argument("--method", choices=FIT_METHODS, default=DEFAULT_METHOD,
                   help=f"fit method (default {DEFAULT_METHOD})")
    p.add_argument("--terms", default="QNBKR", help="noise terms to fit, a subset of QNBKR")
    p.add_argument("--outliers", choices=OUTLIER_POLICIES, default="auto",
                   help="isolated spikes: remove them when few (auto, default), keep, or remove")
    add_bench_argument(p)
    p.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    p.set_defaults(handler=run)


def add_bench_argument(p: argparse.ArgumentParser) -> None:
    """``--bench FILE``: latitude and axis directions, so the bias has the Earth rate removed."""
    p.add_argument("--bench", default=None, metavar="FILE",
                   help="bench file (latitude, axis directions; docs/bench.md): the bias is "
                        "reported with the Earth rate removed (run files: default the run's bench)")


def run(args: argparse.Namespace) -> int:
    """Read the record, analyze every axis, print a table or JSON."""
    from station.services.analyze import AnalyzeRequest, analyze

    result = analyze(AnalyzeRequest(record_source(args), estimator=args.estimator,
                                    deviation=args.deviation, taus=args.taus, method=args.method,
                                    terms=args.terms, outliers=args.outliers, bench=args.bench))
    print_notes("analyze", result.notes)
    if args.json:
        json.dump(result.as_json(), sys.stdout)
        sys.stdout.write("\n")
    else:
        record, selection = result.record, result.selection
        print(f"{args.file}: {record.n_samples} samples at {record.sample_rate_hz:g} Hz, "
              f"{len(result.axes)} axis/axes")
        if selection.start_s > 0 or selection.stop_s is not None:
            print(f"analyzed {selection.start_s:g} s .. "
                  f"{'end' if selection.stop_s is None else f'{selection.stop_s:g} s'} "
                  f"(warm-up {selection.warmup_s:g} s from {selection.warmup_from})")
        print(format_analysis(list(result.axes)))
    return 0
