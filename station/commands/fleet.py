"""``station fleet grade|analyze|report RUN_OR_DIR...``: many runs at once on a Dask cluster.

One task per (run file, unit) on a local cluster of ``--workers`` processes (default: one
per CPU), or on the cluster whose scheduler ``--scheduler tcp://HOST:8786`` names (docs/fleet.md:
a SLURM cluster with dask-jobqueue). Directories are searched for ``.h5`` run files.

* ``grade``: every unit graded as ``station grade`` grades it, and stored in the results
  database (``--db``; ``--no-store`` to skip); ``--json`` prints
  ``{"tasks", "failed": [{"file", "unit", "error"}], "runs": [...]}``, each run the document
  ``station grade RUN --json`` prints;
* ``report``: graded and stored the same way, and each run's spec sheets written into ``--out``;
  where the profile asks for the GMWM (``[test] gmwm_model``) each axis' GMWM terms are
  listed under its unit (value, unit, interval, beside the Allan figure of the same term;
  the model and its J-test p-value), as the sheets and ``--json`` (``"gmwm"``) carry them;
* ``analyze``: every unit analysed as ``station analyze FILE --unit U`` does.

A failed task (a corrupt file, a bad profile, a run too short) is listed with its reason,
the others finish, and the exit status is 1. So is a run the results database did not
take (a server stopped: its stores are tried again with back-off for ``--db-retry``
seconds while the fleet goes on; ``--json``: ``"not_stored": [{"file", "units",
"error"}]``); running the fleet again stores it, and nothing twice. On a terminal a
progress bar on stderr shows the tasks done and the time left; nothing is drawn when
stderr is not a terminal.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

from station.commands import COMMAND_HELP
from station.commands.arguments import (
    add_bench_argument,
    add_database_argument,
    add_output_options,
    add_profile_argument,
    print_warnings,
)
from station.output.report import FORMATS
from station.output.results_backends import redacted
from station.services.fleet_actions import ACTIONS, LOCAL

if TYPE_CHECKING:
    from station.evaluation.grading import UnitGrade
    from station.services.fleet import FleetProgress, FleetResult


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``fleet`` sub-command."""
    p = sub.add_parser(
        "fleet",
        help=COMMAND_HELP["fleet"],
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("action", choices=ACTIONS, help="what to do to every unit of every run")
    p.add_argument(
        "runs",
        nargs="+",
        metavar="RUN_OR_DIR",
        help="run files (.h5; a CSV record is a run of one unit) and directories",
    )
    add_profile_argument(p, default="each run's")
    p.add_argument(
        "--scheduler",
        default=LOCAL,
        metavar="local|ADDRESS",
        help="'local' (default): a local cluster; else a Dask scheduler address (tcp://host:8786)",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="worker processes of the local cluster (default: one per CPU)",
    )
    add_database_argument(p, stores=True, no_store_help="do not store the gradings")
    add_bench_argument(p)
    p.add_argument(
        "--format",
        dest="formats",
        action="append",
        choices=FORMATS,
        default=None,
        help="report: report format; repeatable (default pdf)",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=Path("."),
        metavar="DIR",
        help="report: directory to write into (default the current directory)",
    )
    add_output_options(p, json_help="print one JSON document instead of tables", units=False)
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Build the request, run it with a progress bar, print the result."""
    from station.services.fleet import FleetRequest, fleet

    request = FleetRequest(
        action=args.action,
        sources=tuple(args.runs),
        profile=args.profile,
        bench=args.bench,
        scheduler=args.scheduler,
        workers=args.workers,
        db=args.db,
        store=not args.no_store,
        formats=tuple(args.formats or ["pdf"]),
        out=args.out,
        db_retry_s=args.db_retry,
    )
    bar = ProgressBar(sys.stderr)
    try:
        result = fleet(request, bar)
    finally:
        bar.close()
    if args.json:
        json.dump(result.as_json(), sys.stdout, indent=1, allow_nan=False)
        sys.stdout.write("\n")
    else:
        print(format_fleet(result, None if args.no_store else redacted(request.database)))
    print_warnings("fleet", result.warnings)
    return 0 if result.complete else 1


def _hms(seconds: float) -> str:
    seconds = max(0, round(seconds))
    return f"{seconds // 3600:d}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}"


class ProgressBar:
    """Tasks done / total, failures and the time left, redrawn in place on a terminal;
    nothing at all when the stream is not a terminal (a log, a pipe)."""

    WIDTH = 30

    def __init__(self, stream: TextIO, *, refresh_s: float = 0.2) -> None:
        self.stream = stream
        self.tty = bool(getattr(stream, "isatty", lambda: False)())
        self.refresh_s = refresh_s
        self._last = 0.0
        self._drawn = False

    @staticmethod
    def line(p: FleetProgress, width: int = WIDTH) -> str:
        """The bar's text for one progress report."""
        filled = int(width * p.done / p.total) if p.total else 0
        eta = "--:--" if p.eta_s is None else _hms(p.eta_s)
        failed = f", {p.failed} failed" if p.failed else ""
        return (
            f"[{'#' * filled}{'.' * (width - filled)}] {p.done}/{p.total} tasks{failed}, "
            f"{_hms(p.elapsed_s)} elapsed, ETA {eta}"
        )

    def __call__(self, p: FleetProgress) -> None:
        if not self.tty:
            return
        now = time.monotonic()
        if now - self._last < self.refresh_s and p.done < p.total:
            return
        self._last = now
        self.stream.write("\r\x1b[2K" + self.line(p))
        self.stream.flush()
        self._drawn = True

    def close(self) -> None:
        """End the bar's line."""
        if self._drawn:
            self.stream.write("\n")
            self.stream.flush()


def gmwm_lines(unit: UnitGrade) -> list[str]:
    """A unit's GMWM, indented under its line: per axis the model and its J test, then each
    term with its unit and interval beside the Allan figure of the same term (none when
    the unit was not analysed with the GMWM)."""
    from station.output.report.gmwm_terms import fitted_axes, gmwm_rows, gmwm_summary

    lines = []
    for axis in fitted_axes(unit):
        lines.append(f"    GMWM {gmwm_summary(axis)}")
        lines += [f"      {r.text()}" + (f"  (Allan: {r.allan})" if r.allan else "")
                  for r in gmwm_rows(axis)]
    return lines


def format_fleet(result: FleetResult, database: str | None) -> str:
    """Plain-text summary: one line per unit (grade, or the analysis' first figures), the
    failures, and the totals."""
    lines = []
    for graded in result.runs:
        for u in graded.units:
            flag = "  REVIEW" if u.review else ""
            lines.append(
                f"{graded.run.path}  {u.unit.unit_id}  {u.unit.serial_number or '-'}  "
                f"{graded.profile.ref}  GRADE {u.grade}{flag}"
            )
            lines += gmwm_lines(u)
    for doc in result.analyses:
        selection = doc.get("selection", {})
        unit = selection.get("unit") if isinstance(selection, dict) else ""
        axes = doc.get("axes", [])
        lines.append(
            f"{doc.get('file')}  {unit}  {len(axes) if isinstance(axes, list) else 0} "
            f"axis/axes analysed"
        )
    for f in result.failed:
        lines.append(f"FAILED {f.file}{'  ' + f.unit if f.unit else ''}: {f.error}")
    for n in result.not_stored:
        lines.append(f"NOT STORED {n.file}  {' '.join(n.units)}: {n.error}")
    for path in result.reports:
        lines.append(f"report: {path}")
    summary = (
        f"{result.tasks} tasks, {len(result.failed)} failed, on {result.workers} "
        f"worker(s) in {result.wall_s:.1f} s"
    )
    if database is not None and result.action != "analyze":
        summary += f"; {result.stored} gradings stored in {database}"
    return "\n".join([*lines, summary])
