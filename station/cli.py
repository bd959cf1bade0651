# PYTHON_ARGCOMPLETE_OK
"""The ``station`` command line: a thin layer of argument parsing over station functions.

Each sub-command lives in :mod:`station.commands` as a module with ``register`` (adds its
parser and sets ``handler``) and ``run(args) -> int``; this module only collects them.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

from analysis.errors import AnalysisError
from devices.errors import DeviceError
from station.commands import COMMAND_HELP
from station.commands.conventions import (
    StationParser,
    add_version,
    enable_completion,
    report_unexpected,
)
from station.errors import StationError
from station.logs import configure_logging


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser of ``station``.

    With ``command``, only that sub-command's module is imported and registered (the
    others are listed by name and summary, :data:`station.commands.COMMAND_HELP`): a
    command imports what it needs when it runs, and ``station --help`` imports none of
    scipy, matplotlib, numba, h5py or the device libraries. Without it, every
    sub-command is registered (a completing shell gets that one).
    """
    parser = StationParser(
        prog="station",
        description="Gyro characterization station: record, analyze, grade and report gyros.",
    )
    add_version(parser)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, summary in COMMAND_HELP.items():
        if command is None or name == command:
            importlib.import_module(f"station.commands.{name}").register(sub)
        else:
            sub.add_parser(name, help=summary)
    return parser


def _command_of(argv: Sequence[str]) -> str | None:
    """The sub-command ``argv`` names (its first argument that is one), "" for none, or
    None (every command) when a shell asks for completions."""
    if "_ARGCOMPLETE" in os.environ:
        return None
    return next((a for a in argv if a in COMMAND_HELP), "")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``station`` console script; returns the process exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(_command_of(argv))
    enable_completion(parser)
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
    except Exception as exc:  # a bug or the system: one line, not a traceback
        return report_unexpected(args.command, exc)


if __name__ == "__main__":
    sys.exit(main())
