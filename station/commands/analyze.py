"""``station analyze FILE``: Allan deviation, five-term fit and spec figures of a record."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

from analysis.deviations import DEVIATION_KINDS
from analysis.fit import FIT_METHODS
from station.errors import ProfileError, UsageError
from station.evaluation.analyze import (
    DEFAULT_METHOD,
    OUTLIER_POLICIES,
    analyze_record,
    format_analysis,
)
from station.model.bench import Bench, bench_from_json, load_bench
from station.model.records import RateRecord
from station.storage.csv_records import UNIT_TO_DEG_S
from station.storage.runs import read_record


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


@dataclass(frozen=True)
class RecordSelection:
    """Which part of a record was analyzed (times in s from the record start)."""

    unit: str | None
    axis: str | None
    start_s: float
    stop_s: float | None
    warmup_s: float
    warmup_from: str


def _warmup(args: argparse.Namespace) -> tuple[float, str]:
    """(warm-up to discard in s, where that figure comes from)."""
    from station.model.profiles import load_profile  # profiles: only when a warm-up is needed

    if args.warmup_s is not None:
        return args.warmup_s, "--warmup-s"
    ref = args.profile
    if ref is None and Path(args.file).suffix.lower() in (".h5", ".hdf5"):
        from station.hdf5 import run_attributes

        ref = run_attributes(args.file).get("profile") or None
        if ref is not None:
            try:
                return load_profile(ref).warmup_s, f"profile {ref} (recorded in the run)"
            except ProfileError as exc:
                print(f"note: the run's profile {ref!r} cannot be loaded ({exc}); no warm-up "
                      f"discarded", file=sys.stderr)
                return 0.0, "none"
    if ref is None:
        return 0.0, "none"
    return load_profile(ref).warmup_s, f"profile {ref}"


def load_record(args: argparse.Namespace) -> tuple[RateRecord, RecordSelection]:
    """The record the shared arguments select: file, unit, axis, time slice, warm-up cut.

    The analyzed span starts at ``max(--start-s, warm-up)`` and ends at ``--stop-s``.

    Raises
    ------
    UsageError
        A negative or empty time slice.
    """
    record = read_record(args.file, sample_rate_hz=args.rate, units=args.units, unit=args.unit)
    if args.axis is not None:
        record = record.select(args.axis)
    warmup_s, source = _warmup(args)
    if args.start_s < 0 or warmup_s < 0 or (args.stop_s is not None and
                                            args.stop_s <= max(args.start_s, warmup_s)):
        raise UsageError(f"time slice {args.start_s}..{args.stop_s} s with {warmup_s} s of "
                         f"warm-up is empty or negative")
    start_s = max(args.start_s, warmup_s)
    if start_s > 0 or args.stop_s is not None:
        record = record.slice_time(start_s, args.stop_s)
    return record, RecordSelection(args.unit, args.axis, start_s, args.stop_s, warmup_s, source)


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
    p.add_argument("--taus", choices=("log", "octave", "all"), default="log",
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


def bench_for(bench_file: str | None, bench_json: str = "") -> Bench | None:
    """The bench of ``--bench FILE``, else the one a run file recorded, else None."""
    return load_bench(bench_file) if bench_file is not None else bench_from_json(bench_json)


def run(args: argparse.Namespace) -> int:
    """Read the record, analyze every axis, print a table or JSON."""
    record, selection = load_record(args)
    recorded = ""
    if args.bench is None and Path(args.file).suffix.lower() in (".h5", ".hdf5"):
        from station.hdf5 import run_attributes

        recorded = run_attributes(args.file).get("bench", "")
    estimator = args.estimator or ("clusters" if args.deviation == "adev" else "overlapping")
    axes = analyze_record(record, estimator=estimator, taus=args.taus, method=args.method,
                          terms=args.terms, outliers=args.outliers,
                          bench=bench_for(args.bench, recorded), deviation_kind=args.deviation)
    if args.json:
        json.dump({"file": str(args.file), "axes": [a.as_json() for a in axes],
                   "selection": asdict(selection)}, sys.stdout)
        sys.stdout.write("\n")
    else:
        print(f"{args.file}: {record.n_samples} samples at {record.sample_rate_hz:g} Hz, "
              f"{len(axes)} axis/axes")
        if selection.start_s > 0 or selection.stop_s is not None:
            print(f"analyzed {selection.start_s:g} s .. "
                  f"{'end' if selection.stop_s is None else f'{selection.stop_s:g} s'} "
                  f"(warm-up {selection.warmup_s:g} s from {selection.warmup_from})")
        print(format_analysis(axes))
    return 0
