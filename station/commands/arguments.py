"""Arguments several commands share, and how a command shows a workflow's notes."""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING

from analysis.units import UNIT_FAMILIES, UnitFamily, unit_family
from station.errors import UsageError
from station.model.durations import parse_duration
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
    add_accel_units_argument(parser)
    parser.add_argument("--axis", default=None, help="analyze only this axis (column name)")
    add_slice_arguments(parser)


def add_accel_units_argument(parser: argparse.ArgumentParser) -> None:
    """``--accel-units``: the unit of a CSV record's ``accel_*`` columns (checked by the
    reader, so that a wrong one is one line naming it)."""
    parser.add_argument("--accel-units", default="m/s^2", metavar="UNIT",
                        help="unit of the accel_* (acc_*) columns: m/s^2 (default), g or mg")


def add_slice_arguments(
    parser: argparse.ArgumentParser, *, unit_default: str = "the first"
) -> None:
    """``--unit``, ``--start-s``, ``--stop-s``, ``--profile``, ``--warmup-s``: which unit of a
    run file and which part of its record (:class:`station.services.records.RecordSource`)."""
    parser.add_argument(
        "--unit",
        default=None,
        help=f"run files: the unit (unit1, unit2, ... or its serial number; "
        f"default {unit_default})",
    )
    parser.add_argument(
        "--start-s",
        type=float,
        default=0.0,
        metavar="S",
        help="analyze from S seconds after the record start (default 0)",
    )
    parser.add_argument(
        "--stop-s",
        type=float,
        default=None,
        metavar="S",
        help="analyze up to S seconds after the record start (default: end)",
    )
    parser.add_argument(
        "--profile",
        default=None,
        help="product profile whose warm-up (warmup_s) is discarded; run "
        "files default to the profile they were recorded with",
    )
    parser.add_argument(
        "--warmup-s",
        type=float,
        default=None,
        metavar="S",
        help="warm-up to discard from the start, s (overrides the profile)",
    )


def record_source(args: argparse.Namespace) -> RecordSource:
    """The :class:`RecordSource` the shared record arguments name."""
    from station.services.records import RecordSource

    return RecordSource(
        args.file,
        rate_hz=args.rate,
        units=args.units,
        accel_units=args.accel_units,
        axis=args.axis,
        unit=args.unit,
        start_s=args.start_s,
        stop_s=args.stop_s,
        profile=args.profile,
        warmup_s=args.warmup_s,
    )


def add_output_units_argument(parser: argparse.ArgumentParser) -> None:
    """``--output-units deg|rad``: the unit family of every figure the command prints (its
    tables, its ``--json`` keys, its files; ``docs/units.md``). ``--units`` stays the unit of a
    CSV record's columns."""
    parser.add_argument(
        "--output-units",
        choices=UNIT_FAMILIES,
        default="deg",
        help="unit family of the figures printed: deg (deg/h, deg/sqrt(h), deg/h^1.5, deg/h^2, "
        "urad; default) or rad (rad/s, rad/s/sqrt(Hz), rad/s^2/sqrt(Hz), rad/s^2, rad); JSON "
        "keys name the unit (docs/units.md)",
    )


def output_family(args: argparse.Namespace) -> UnitFamily:
    """The :class:`UnitFamily` ``--output-units`` names (deg where the command has none)."""
    return unit_family(getattr(args, "output_units", "deg"))


def print_json(doc: object, family: UnitFamily, **dump: object) -> None:
    """``doc`` (a deg-family ``--json`` document) in ``family`` on stdout, one line or as
    ``dump`` says (``indent=1``, ``allow_nan=False``)."""
    from station.output.json_units import in_family

    json.dump(in_family(doc, family), sys.stdout, **dump)  # type: ignore[arg-type]
    sys.stdout.write("\n")


def print_notes(command: str, notes: tuple[str, ...]) -> None:
    """A workflow's notes for the operator, on stderr (``station COMMAND: note: ...``)."""
    for note in notes:
        print(f"station {command}: note: {note}", file=sys.stderr)


def add_bench_argument(p: argparse.ArgumentParser) -> None:
    """``--bench FILE``: latitude and axis directions, so the bias has the Earth rate removed."""
    p.add_argument(
        "--bench",
        default=None,
        metavar="FILE",
        help="bench file (latitude, axis directions; docs/bench.md): the bias is "
        "reported with the Earth rate removed (run files: default the run's bench)",
    )


def add_database_argument(p: argparse.ArgumentParser, *, stores: bool = False) -> None:
    """``--db FILE|URL``: the results database, an SQLite file or a PostgreSQL URL; a
    command that ``stores`` gradings also takes ``--db-retry S``, how long a database that
    is away is waited for (``args.db_retry``, s)."""
    from station.output.results_backends import database_location

    p.add_argument(
        "--db",
        type=database_location,
        default=None,
        metavar="FILE|URL",
        help="results database: an SQLite file or a postgresql://USER@HOST/DB URL "
        "(default: $STATION_RESULTS_DB or ~/.local/share/gyro-station)",
    )
    if stores:
        from station.output.results_backends import STORE_RETRY_S

        p.add_argument(
            "--db-retry",
            type=_seconds_or_zero,
            default=STORE_RETRY_S,
            metavar="S",
            help="how long a results database that is away is tried again, with back-off, "
            f"before a grading is listed as not stored, s (default {STORE_RETRY_S:g})",
        )


def _seconds_or_zero(text: str) -> float:
    """A time >= 0 s for argparse."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"{text!r}: give 0 s or more")
    return value


def duration_type(text: str) -> float:
    """A duration in s for argparse (:func:`station.model.durations.parse_duration`).

    Raises
    ------
    argparse.ArgumentTypeError
        If the text is not a positive duration.
    """
    try:
        return parse_duration(text)
    except UsageError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def print_warnings(command: str, warnings: tuple[str, ...]) -> None:
    """A workflow's warnings, on stderr (``station COMMAND: warning: ...``)."""
    for text in warnings:
        print(f"station {command}: warning: {text}", file=sys.stderr)
