"""What every ``station`` command line shares: no abbreviated options, one-line errors with
exit status 2, ``--version``, shell completion.

* Options are never abbreviated (``allow_abbrev=False``): ``--unit`` is not taken for
  ``--units``, and an option added later cannot change what an old script meant.
* Help shows plain text (the docstrings' reStructuredText markup is taken out) and every
  option has its line.
* A bad command line is one line on stderr, ``station COMMAND: error: ...`` with a pointer to
  ``--help``, and exit status 2 (argparse's usage block is not repeated above it).
* ``station --version`` prints the installed package's version.
* Shell completion through argcomplete when it is installed (``eval "$(register-python-argcomplete
  station)"`` in bash); nothing is imported for it unless the shell asks.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import sys
from collections.abc import Callable, Sequence
from typing import Any, NoReturn

from station.model.version import software_version

#: Set to show the traceback of an unexpected error (a bug) instead of one line.
TRACEBACK_ENV = "STATION_TRACEBACK"


class StationParser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` (and, through ``add_subparsers``, every
    sub-command's) that never abbreviates options and reports errors on one line."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        kwargs["allow_abbrev"] = False
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]

    def parse_args(self, args=None, namespace=None):
        """As argparse's, but arguments no option takes are reported by the sub-command's parser
        (``station analyze: error: unrecognized arguments: ...``)."""
        ns, extras = self.parse_known_args(args, namespace)
        if extras:
            target = next(
                (
                    a.choices.get(getattr(ns, a.dest, None) or "")
                    for a in self._actions
                    if isinstance(a, argparse._SubParsersAction)
                ),
                None,
            )
            parser = target or self
            hint = getattr(parser, "extras_hint", "")
            parser.error(f"unrecognized arguments: {' '.join(extras)}{hint}")
        return ns

    def format_help(self) -> str:
        """argparse's help without the docstrings' reStructuredText markup (``code``,
        :mod:`x`), which a terminal shows literally."""
        return plain_text(super().format_help())

    def error(self, message: str) -> NoReturn:
        """One line, ``PROG: error: MESSAGE (PROG --help lists the options)``, exit status 2."""
        self.exit(2, f"{self.prog}: error: {message} ({self.prog} --help lists the options)\n")


def hint_several_runs(parser: argparse.ArgumentParser, command: str) -> None:
    """Arguments ``parser`` (``station COMMAND``, one run) does not take are most likely
    more runs: its error points to ``station fleet COMMAND``, which takes many."""
    parser.extras_hint = (  # type: ignore[attr-defined]
        f"; station {command} takes one file: for several, station fleet {command} "
        "FILE_OR_DIR..."
    )


def plain_text(text: str) -> str:
    """``text`` without reStructuredText roles (``:mod:`x``` -> ``x``) and literals
    (````x```` -> ``x``)."""
    text = re.sub(r":\w+:`~?([^`]*)`", r"\1", text)
    return re.sub(r"``([^`]*)``", r"\1", text)


def add_version(parser: argparse.ArgumentParser) -> None:
    """``--version``: ``station X.Y.Z``."""
    parser.add_argument(
        "--version",
        action=_VersionAction,
        help="print the station software's version and exit",
    )


class _VersionAction(argparse._VersionAction):
    """argparse's ``version`` action, the version looked up only when asked for: the
    lookup imports importlib.metadata (40-60 ms), which no other use of a parser needs."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: str | Sequence[Any] | None, option_string: str | None = None
                 ) -> None:
        self.version = f"%(prog)s {software_version()}"
        super().__call__(parser, namespace, values, option_string)


def enable_completion(
    parser: argparse.ArgumentParser, *, exit_method: Callable[[int], object] = os._exit
) -> None:
    """Answer a completing shell (argcomplete's ``_ARGCOMPLETE`` request) and exit through
    ``exit_method``; a no-op otherwise, and when argcomplete is not installed."""
    if "_ARGCOMPLETE" not in os.environ:
        return
    try:
        import argcomplete
    except ImportError:
        return
    argcomplete.autocomplete(parser, exit_method=exit_method)


def report_unexpected(command: str, exc: BaseException) -> int:
    """One line for an error no check anticipated; the traceback only with ``STATION_TRACEBACK=1``.

    Returns the exit status: 2 for an operating-system error (a path, a permission, a full
    disk: the operator can act on it), 1 for anything else (a bug to report).
    """
    if os.environ.get(TRACEBACK_ENV):
        raise exc
    if isinstance(exc, BrokenPipeError):  # `station ... | head`: the reader has what it wanted
        with contextlib.suppress(OSError, ValueError, io.UnsupportedOperation):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    if isinstance(exc, OSError):
        where = f": {exc.filename}" if exc.filename else ""
        print(f"station {command}: error: {exc.strerror or exc}{where}", file=sys.stderr)
        return 2
    print(
        f"station {command}: internal error: {type(exc).__name__}: {exc} (please report it; "
        f"{TRACEBACK_ENV}=1 shows the traceback)",
        file=sys.stderr,
    )
    return 1
