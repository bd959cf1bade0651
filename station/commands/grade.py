"""``station grade RUN [--profile P]``: every figure with its confidence interval, and the grade.

Prints a table per unit (or, with ``--json``, one JSON document: the run, and per unit
its figures with intervals, limits and verdicts; docs/json.md) and stores each graded unit in
the results database (``--db``, default ``$STATION_RESULTS_DB`` or the user's data directory;
``--no-store`` to skip). A database that is away is tried again with back-off for
``--db-retry`` seconds; a grading it did not take is said in one line on stderr, exit
status 1 (grading the run again stores it once). Re-grading a stored run with another
profile needs only the file.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from analysis.units.conversions import DEG_FAMILY, UnitFamily
from station.commands import COMMAND_HELP
from station.commands.arguments import (
    add_bench_argument,
    add_csv_format_arguments,
    add_database_argument,
    add_output_options,
    add_profile_argument,
    output_family,
    print_json,
    print_warnings,
    serial_number,
)
from station.commands.conventions import hint_several_runs

if TYPE_CHECKING:
    from station.evaluation.grading import RunGrade
    from station.services.grade import GradeRequest


def add_grading_arguments(p: argparse.ArgumentParser) -> None:
    """Arguments shared by the commands that grade a run (grade, report)."""
    p.add_argument("run", help="run file: a recorder HDF5 run or a CSV record (one unit)")
    add_profile_argument(p, default="the run's")
    add_csv_format_arguments(p)
    p.add_argument(
        "--unit",
        action="append",
        default=[],
        metavar="ID",
        help="grade only this unit (id or serial number); repeatable",
    )
    p.add_argument("--serial", default=None, type=serial_number,
                   help="serial number of a CSV record's unit")
    p.add_argument("--lsb", type=float, default=None, metavar="DEG_S",
                   help="the rate word's LSB, deg/s, of a CSV record (a run file keeps its "
                        "link's; default: read off the values); docs/grading.md, Resolution")
    p.add_argument("--lot", default=None, help="lot of the run (overrides the run's)")
    p.add_argument("--operator", default=None, help="operator of the run (overrides the run's)")
    add_database_argument(p, stores=True,
                          no_store_help="do not store the grading in the database")
    add_bench_argument(p)


def grade_request(args: argparse.Namespace) -> GradeRequest:
    """The :class:`GradeRequest` the shared grading arguments name."""
    from station.services.grade import GradeRequest, RunSource

    run = RunSource(
        args.run,
        rate_hz=args.rate,
        units=args.units,
        accel_units=args.accel_units,
        serial=args.serial,
        lsb_deg_s=args.lsb,
        lot=args.lot,
        operator=args.operator,
    )
    return GradeRequest(
        run,
        profile=args.profile,
        units=tuple(args.unit),
        bench=args.bench,
        db=args.db,
        store=not args.no_store,
        db_retry_s=args.db_retry,
    )


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``grade`` sub-command."""
    p = sub.add_parser("grade", help=COMMAND_HELP["grade"], description=__doc__)
    add_grading_arguments(p)
    add_output_options(p, json_help="print one JSON document instead of tables")
    hint_several_runs(p, "grade")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Grade, print, store; 1 when the database did not take the grading."""
    from station.errors import GradingNotStoredError
    from station.services.grade import grade, store_grading

    request = grade_request(args)
    result = grade(request)
    print_warnings("grade", result.warnings)
    family = output_family(args)
    if args.json:
        print_json(result.graded.as_json(), family, indent=1, allow_nan=False)
    else:
        print(format_grade(result.graded, family))
    sys.stdout.flush()  # the grades are shown even when the database cannot take them
    if request.store:
        try:
            store_grading(result.graded, request.database, retry_s=request.db_retry_s)
        except GradingNotStoredError as exc:
            print(f"station grade: {exc}; grade it again with the same --db when the database "
                  f"answers: it is stored once", file=sys.stderr)
            return 1
    return 0


def _num(v: float | None) -> str:
    return "-" if v is None else f"{v:.4g}"


def format_grade(graded: RunGrade, family: UnitFamily = DEG_FAMILY) -> str:
    """Plain-text tables: per unit, per axis, each figure's value, interval, limit and verdict
    (in ``family``)."""
    # here, not at the top: these modules draw sheets too (matplotlib), and ``--help`` and a
    # refused argument must not import it
    from station.output.report.common import analysis_lines
    from station.output.report.plateau_sheet import plateau_lines
    from station.output.report.sequence_sheet import sequence_lines

    p = graded.profile
    lines = [
        f"profile {p.ref} ({p.path}), rule {p.rule}, {p.confidence:.0%} intervals, "
        f"grades {' > '.join(p.grades)} > {p.reject}; arw and bias instability from the "
        f"{p.figure_source}"
    ]
    for u in graded.units:
        lines.append("")
        flag = "  REVIEW" if u.review else ""
        lines.append(
            f"unit {u.unit.unit_id}  model {u.unit.model or p.model}  serial "
            f"{u.unit.serial_number or '-'}  GRADE {u.grade}{flag}"
        )
        for note in u.notes:
            lines.append(f"  note: {note}")
        for line in analysis_lines(u, family):
            lines.append(f"  {line}")
        for a in u.axes:
            reach = f" (indeterminate at {a.could_reach})" if a.could_reach else ""
            review = " (review)" if a.review else ""
            lines.append(
                f"  axis {a.axis}: {a.grade}{reach}{review}; limits of grade {a.deciding_grade}"
            )
            lines.append(
                f"    {'figure':<40} {'value':>10} {'interval':>23} {'limit':>10}  verdict"
            )
            for f in a.figures:
                unit = f.spec.unit
                limit = family.value(f.spec.limits.get(a.deciding_grade), unit)
                verdict = f.verdicts.get(a.deciding_grade, "pass") if f.spec.graded else "(info)"
                label = f"{f.spec.label} [{family.label(unit)}]"
                interval = (f"[{_num(family.value(f.ci_low, unit))}, "
                            f"{_num(family.value(f.ci_high, unit))}]")
                lines.append(
                    f"    {label:<40} {_num(family.value(f.value, unit)):>10} {interval:>23} "
                    f"{_num(limit):>10}  {verdict}"
                )
        if u.sequence is not None:
            lines += [f"  {line}" for line in sequence_lines(u.sequence)]
            lines += [f"  {line}" for line in plateau_lines(u.sequence.plateaus)]
    return "\n".join(lines)
