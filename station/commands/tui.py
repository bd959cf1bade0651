"""``station tui``: the terminal user interface (set up runs, watch them live, spec sheets).

Keyboard first: the bindings of each screen are shown in its footer. The recorder runs in
a process of its own, so quitting (or losing) the TUI never stops a run; reopening the
TUI attaches to a run in progress in the runs folder.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from station.commands import COMMAND_HELP
from station.commands.arguments import add_database_argument


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``tui`` sub-command."""
    p = sub.add_parser("tui", help=COMMAND_HELP["tui"],
                       description=__doc__)
    p.add_argument("--runs", type=Path, default=Path("runs"), metavar="DIR",
                   help="folder of the run files (default ./runs)")
    p.add_argument("--reports", type=Path, default=Path("reports"), metavar="DIR",
                   help="folder for exported reports (default ./reports)")
    add_database_argument(p, stores=True)
    p.add_argument("--no-check", action="store_true",
                   help="do not check that each unit answers when it is added")
    p.add_argument("--poll", type=float, default=1.0, metavar="S",
                   help="time between reads of a live run file, s (default 1)")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Run the TUI until the operator quits."""
    from station.output.results import default_database_path
    from station.tui.app import StationApp, TuiSettings

    settings = TuiSettings(runs_dir=args.runs, reports_dir=args.reports,
                           db_path=args.db or default_database_path(), db_retry_s=args.db_retry,
                           check_units=not args.no_check, poll_s=args.poll)
    app = StationApp(settings)
    app.run()
    if app.crash_message:
        print(app.crash_message, file=sys.stderr)
        return 1
    return 0
