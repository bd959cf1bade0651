"""The ``station`` command line: a thin layer of argument parsing over station functions.

Each sub-command lives in :mod:`station.commands` as a module with ``register`` (adds its
parser and sets ``handler``) and ``run(args) -> int``; this module only collects them.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from analysis.errors import AnalysisError
from devices.errors import DeviceError
from station.commands import (
    analyze,
    davar,
    demo,
    devices,
    fleet,
    grade,
    model,
    reconcile,
    record,
    recover,
    report,
    reproduce,
    results,
    simulate,
    tui,
    watch,
)
from station.errors import StationError
from station.logs import configure_logging

COMMANDS: tuple = (
    demo,
    analyze,
    reproduce,
    simulate,
    model,
    davar,
    devices,
    grade,
    report,
    fleet,
    results,
    record,
    watch,
    recover,
    reconcile,
    tui,
)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``station`` with every sub-command registered."""
    parser = argparse.ArgumentParser(
        prog="station",
        description="Gyro characterization station: record, analyze, grade and report gyros.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``station`` console script; returns the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    configure_logging()
    try:
        return int(args.handler(args) or 0)
    except (StationError, AnalysisError, DeviceError) as exc:
        print(f"station {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except FileNotFoundError as exc:
        print(f"station {args.command}: error: no such file: {exc.filename}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"station {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
