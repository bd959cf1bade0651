"""Arguments several commands share, and how a command shows a workflow's notes."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from analysis.units.conversions import UNIT_FAMILIES, UnitFamily, unit_family
from station.errors import UsageError
from station.model.durations import parse_duration
from station.storage.csv_records import UNIT_TO_DEG_S

if TYPE_CHECKING:
    from station.output.results_backends import DatabaseLocation
    from station.services.progress import Progress
    from station.services.records import RecordSource


#: The record a command reads, as ``FILE`` (analyze, davar, export) or another name.
RECORD_FILE_HELP = ("rate record: CSV or CSV.gz (header row; optional time column), or a run "
                    "file (.h5) from station record")


def add_record_source(
    parser: argparse.ArgumentParser,
    *,
    metavar: str | None = None,
    file_help: str = RECORD_FILE_HELP,
    axis_help: str = "analyze only this axis (column name)",
    unit_default: str = "the first",
) -> argparse._ArgumentGroup:
    """The record source every command that reads a rate record shares (analyze, davar,
    export, reconcile): ``FILE``, its CSV format, the axis, and for run files the unit and
    the part of its record (:class:`station.services.records.RecordSource`,
    :func:`record_source`). One option more for all of them is one line here."""
    group = parser.add_argument_group("record source")
    group.add_argument("file", metavar=metavar, help=file_help)
    add_csv_format_arguments(group)
    group.add_argument("--axis", default=None, help=axis_help)
    group.add_argument(
        "--unit",
        default=None,
        help=f"run files: the unit (unit1, unit2, ... or its serial number; "
        f"default {unit_default})",
    )
    group.add_argument("--start-s", type=float, default=0.0, metavar="S",
                       help="analyze from S seconds after the record start (default 0)")
    group.add_argument("--stop-s", type=float, default=None, metavar="S",
                       help="analyze up to S seconds after the record start (default: end)")
    group.add_argument("--profile", default=None,
                       help="product profile whose warm-up (warmup_s) is discarded; run "
                       "files default to the profile they were recorded with")
    group.add_argument("--warmup-s", type=float, default=None, metavar="S",
                       help="warm-up to discard from the start, s (overrides the profile)")
    return group


def add_csv_format_arguments(group: argparse._ActionsContainer) -> None:
    """``--rate`` and ``--units``: how a CSV record's rate columns read (a run file says)."""
    group.add_argument("--rate", type=float, default=None, metavar="HZ",
                       help="sample rate in Hz (required when a CSV has no time column)")
    group.add_argument("--units", choices=sorted(UNIT_TO_DEG_S), default="deg/s",
                       help="unit of a CSV's rate columns (default deg/s)")
    # checked by the reader, so that a wrong one is one line naming it
    group.add_argument("--accel-units", default="m/s^2", metavar="UNIT",
                       help="unit of a CSV's accel_* (acc_*) columns: m/s^2 (default), g or mg")


def add_output_options(
    parser: argparse.ArgumentParser,
    *,
    json_help: str | None,
    png_help: str | None = None,
    csv_help: str | None = None,
    quiet_help: str | None = None,
    units: bool = True,
) -> argparse._ArgumentGroup:
    """The output options commands share, each added where its help is given: ``--png``
    (``args.png``), ``--csv``, ``--output-units`` (with ``units``), ``--json``,
    ``--quiet``."""
    group = parser.add_argument_group("output")
    if png_help is not None:
        group.add_argument("--png", type=Path, default=None, metavar="OUT.png", help=png_help)
    if csv_help is not None:
        group.add_argument("--csv", type=Path, default=None, metavar="OUT.csv", help=csv_help)
    if units:
        add_output_units_argument(group)
    if json_help is not None:
        group.add_argument("--json", action="store_true", help=json_help)
    if quiet_help is not None:
        group.add_argument("--quiet", action="store_true", help=quiet_help)
    return group


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


def add_output_units_argument(parser: argparse._ActionsContainer) -> None:
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


def add_database_argument(
    p: argparse.ArgumentParser, *, stores: bool = False, no_store_help: str | None = None
) -> argparse._ArgumentGroup:
    """``--db FILE|URL``: the results database, an SQLite file or a PostgreSQL URL; a
    command that ``stores`` gradings also takes ``--db-retry S``, how long a database that
    is away is waited for (``args.db_retry``, s), and with ``no_store_help`` ``--no-store``."""
    group = p.add_argument_group("results database")
    group.add_argument(
        "--db",
        type=_database_argument,
        default=None,
        metavar="FILE|URL",
        help="results database: an SQLite file or a postgresql://USER@HOST/DB URL "
        "(default: $STATION_RESULTS_DB or ~/.local/share/gyro-station)",
    )
    if stores:
        from station.output.results_backends import STORE_RETRY_S

        group.add_argument(
            "--db-retry",
            type=_seconds_or_zero,
            default=STORE_RETRY_S,
            metavar="S",
            help="how long a results database that is away is tried again, with back-off, "
            f"before a grading is listed as not stored, s (default {STORE_RETRY_S:g})",
        )
    if no_store_help is not None:
        group.add_argument("--no-store", action="store_true", help=no_store_help)
    return group


def _database_argument(text: str) -> DatabaseLocation:
    """``--db`` as a location, refused at once (one line, exit 2, nothing created) when it
    cannot be a results database (:class:`DatabaseLocationError`)."""
    from station.output.results_backends import (
        DatabaseLocationError,
        check_database_file,
        database_location,
    )

    try:
        location = database_location(text)
        if isinstance(location, Path):
            check_database_file(location)
    except DatabaseLocationError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from exc
    return location


def add_profile_argument(p: argparse._ActionsContainer, *, default: str) -> None:
    """``--profile P``: the product profile to grade against (``default`` says which
    when none is given)."""
    p.add_argument("--profile", default=None, metavar="P",
                   help=f"product profile: a name in profiles/ or a TOML file (default: {default})")


def add_fog_indicators(p: argparse._ActionsContainer, *, required: bool) -> None:
    """``--arw``, ``--bias-stability``, ``--average-s``, ``--correlation-s``: the
    white-noise-plus-Markov FOG of a data sheet's two indicators (docs/fog-model.md)."""
    p.add_argument("--arw", type=float, required=required, metavar="DEG_RT_H",
                   help="angle random walk in deg/sqrt(h)")
    p.add_argument("--bias-stability", type=float, required=required, metavar="DEG_H",
                   help="bias stability in deg/h (1 sigma of --average-s averages)")
    p.add_argument("--average-s", type=float, default=100.0, metavar="S",
                   help="averaging time of the bias stability in s (default 100)")
    p.add_argument("--correlation-s", type=float, metavar="S",
                   help="correlation time of the Markov process in s (default: --average-s)")


def _seconds_or_zero(text: str) -> float:
    """A time >= 0 s for argparse."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"{text!r}: give 0 s or more")
    return value


def serial_number(text: str) -> str:
    """A unit's serial number for argparse: text with something in it (surrounding white
    space dropped).

    Raises
    ------
    argparse.ArgumentTypeError
        If the text is empty or only white space.
    """
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty serial number: give the unit's serial")
    return text.strip()


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


def stderr_progress(
    prefix: str = "", *, quiet: bool = False, terminal_only: bool = False
) -> Callable[[Progress], None]:
    """A progress callback that prints each step's text as ``PREFIXtext ...`` on stderr
    (nothing with ``quiet``; with ``terminal_only`` only when stderr is a terminal)."""

    def progress(step: Progress) -> None:
        if not quiet and (not terminal_only or sys.stderr.isatty()):
            print(f"{prefix}{step.text} ...", file=sys.stderr, flush=True)

    return progress


class _Answer(Protocol):
    @property
    def notes(self) -> tuple[str, ...]: ...

    def as_json(self) -> object: ...


def print_notes_or_json(command: str, answer: _Answer, args: argparse.Namespace,
                        **dump: object) -> bool:
    """A record-reading workflow's notes on stderr and, with ``--json``, its document in the
    ``--output-units`` family on stdout; True when the JSON was printed (nothing else to)."""
    print_notes(command, answer.notes)
    if args.json:
        print_json(answer.as_json(), output_family(args), **dump)
    return bool(args.json)
