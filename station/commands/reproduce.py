"""``station reproduce lv2015``: re-run a paper's Monte Carlo and print its table beside ours."""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import TYPE_CHECKING

from station.commands import COMMAND_HELP

if TYPE_CHECKING:
    from station.services.progress import Progress


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``reproduce`` sub-command."""
    p = sub.add_parser("reproduce", help=COMMAND_HELP["reproduce"],
                       description=__doc__)
    p.add_argument("paper", choices=("lv2015",), help="which study to re-run")
    p.add_argument(
        "--runs", type=int, default=30, help="simulated runs per gyro (default 30, as the paper)"
    )
    p.add_argument("--seed", type=int, default=1, help="seed of the whole study (default 1)")
    p.add_argument("--workers", type=int, default=2, help="processes to use (default 2)")
    p.add_argument("--json", action="store_true", help="print the table as JSON")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Run the study with a progress line on stderr, print the table."""
    from station.evaluation.reproduce import format_reproduction
    from station.services.reproduce import ReproduceRequest, reproduce

    start = time.monotonic()

    def progress(step: Progress) -> None:
        if sys.stderr.isatty() or step.done == step.total:
            elapsed = time.monotonic() - start
            print(f"\r{step.text}, {elapsed:.1f} s", end="" if step.done < step.total else "\n",
                  file=sys.stderr, flush=True)

    table = reproduce(ReproduceRequest(args.paper, args.runs, args.seed, args.workers), progress)
    if args.json:
        json.dump(table, sys.stdout)
        sys.stdout.write("\n")
    else:
        print(format_reproduction(table))
    return 0
