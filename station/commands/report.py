"""``station report RUN --format pdf|html|json|csv --out DIR``: spec sheets of a graded run.

Grades the run with the profile (given, or the run's) exactly as ``station grade`` does,
writes the report file (PDF: one page per unit; HTML: self-contained; JSON: the schema of
docs/report-json-schema.md; CSV: one row per unit and axis) and records it in the results
database against each unit's grading (storing the grading first when it is not there yet).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from station.commands.arguments import print_warnings
from station.commands.grade import add_grading_arguments, grade_request
from station.output.report import FORMATS


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``report`` sub-command."""
    p = sub.add_parser("report", help="write spec-sheet reports (PDF, HTML, JSON, CSV) of a run",
                       description=__doc__)
    add_grading_arguments(p)
    p.add_argument("--format", dest="formats", action="append", choices=FORMATS, default=None,
                   help="report format; repeatable (default pdf)")
    p.add_argument("--out", type=Path, default=Path("."), metavar="DIR",
                   help="directory to write into (created; default the current directory)")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Grade, write each report, record the files, print their paths."""
    from station.services.report import ReportRequest, report

    result = report(ReportRequest(grade_request(args), tuple(args.formats or ["pdf"]), args.out))
    print_warnings("report", result.warnings)
    for _, path in result.files:
        print(path)
    return 0
