"""``station report RUN --format pdf|html|json|csv --out DIR``: spec sheets of a graded run.

Grades the run with the profile (given, or the run's) exactly as ``station grade`` does,
writes the report file (PDF: per unit a first page to send, its other pages and its test
record, each page numbered; HTML: self-contained; JSON: the schema of
docs/report-json-schema.md; CSV: one row per unit and axis) and records it in the results
database against each unit's grading (storing the grading first when it is not there yet).
--header sheet.toml puts the test house on the sheet: company, logo, station, conditions,
signature lines.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from station.commands import COMMAND_HELP
from station.commands.arguments import add_output_options, output_family, print_warnings
from station.commands.conventions import hint_several_runs
from station.commands.grade import add_grading_arguments, grade_request
from station.model.sheet_header import HEADER_ENV
from station.output.report import FORMATS


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``report`` sub-command."""
    p = sub.add_parser("report", help=COMMAND_HELP["report"],
                       description=__doc__)
    add_grading_arguments(p)
    p.add_argument("--format", dest="formats", action="append", choices=FORMATS, default=None,
                   help="report format; repeatable (default pdf)")
    p.add_argument("--header", type=Path, default=None, metavar="FILE",
                   help="sheet header (TOML: company, logo, station, conditions, approval; "
                        "default $STATION_SHEET_HEADER when set); $STATION_NAME names the station "
                        "when the header does not")
    p.add_argument("--method", choices=("allan", "gmwm"), default=None,
                   help="gmwm: each unit's sheet adds a GMWM page (its terms beside the Allan "
                        "read-offs, the wavelet variance with both models' curves); allan: "
                        "none; default what the profile's [test] gmwm_model says")
    p.add_argument("--model", default=None, metavar="MODEL",
                   help="--method gmwm: the model, terms joined by '+' from wn, qn, gm, ar1, bi, "
                        "rw, dr (e.g. 'wn+gm+rw'), or auto: ranked by the WIC (default the "
                        "profile's gmwm_model, else auto)")
    p.add_argument("--out", type=Path, default=Path("."), metavar="DIR",
                   help="directory to write into (created; default the current directory)")
    add_output_options(
        p, json_help='print {"files": [{"format", "path"}], "warnings"} as one JSON object'
    )
    hint_several_runs(p, "report")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Grade, write each report, record the files, print their paths."""
    from station.services.report import ReportRequest, report

    header = args.header or (Path(os.environ[HEADER_ENV]) if os.environ.get(HEADER_ENV) else None)
    result = report(ReportRequest(grade_request(args), tuple(args.formats or ["pdf"]), args.out,
                                  header, output_family(args), method=args.method,
                                  gmwm_model=args.model))
    print_warnings("report", result.warnings)
    if args.json:
        json.dump({"files": [{"format": f, "path": str(path)} for f, path in result.files],
                   "warnings": list(result.warnings)}, sys.stdout)
        sys.stdout.write("\n")
        return 0
    for _, path in result.files:
        print(path)
    return 0
