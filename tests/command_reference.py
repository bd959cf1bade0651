"""docs/reference/commands.md, written from the live ``station`` parser.

``python -m tests.command_reference`` rewrites the page; tests/test_docs.py fails when the
page differs from what this module writes, so the page never falls behind ``--help``. The
page is rendered here from the parser's actions (not from argparse's formatted help), so it
depends on neither the terminal's width nor the Python version's help layout.
"""

from __future__ import annotations

import argparse
import textwrap
from pathlib import Path

from station.cli import build_parser
from station.commands import COMMAND_HELP
from station.commands.conventions import plain_text

PAGE = Path(__file__).resolve().parents[1] / "docs" / "reference" / "commands.md"

HEADER = """\
# Commands

Every `station` command with its description and options, as `station COMMAND --help`
prints them (one section per command and sub-command). This page is written by
`python -m tests.command_reference`, and `tests/test_docs.py` fails when it differs from
the live parser. The conventions every command shares (`--json`, `--output-units`, exit
statuses, shell completion) are in [Command-line conventions](../cli.md).

| command | what it does |
|---|---|
"""


def _cell(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


def _wrapped(text: str) -> str:
    paragraphs = [" ".join(p.split()) for p in plain_text(text).split("\n\n") if p.strip()]
    return "\n\n".join(textwrap.fill(p, 92) for p in paragraphs)


def _subparsers(parser: argparse.ArgumentParser) -> argparse._SubParsersAction | None:
    return next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)),
                None)


def _option_row(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    formatter = parser._get_formatter()
    if action.option_strings:
        name = ", ".join(f"`{s}`" for s in action.option_strings)
    else:
        name = f"`{action.metavar or action.dest}`"
    if action.nargs == 0:
        argument = ""
    elif action.choices is not None and not action.metavar:
        argument = "`{" + ",".join(str(c) for c in action.choices) + "}`"
    else:
        metavar = action.metavar or (action.dest.upper() if action.option_strings
                                     else action.dest)
        argument = f"`{metavar}`" if action.option_strings else ""
    help_text = formatter._expand_help(action) if action.help else ""
    return f"| {name} | {_cell(argument)} | {_cell(plain_text(help_text))} |"


def _section(title: str, parser: argparse.ArgumentParser, level: int) -> list[str]:
    lines = [f"{'#' * level} `{title}`", ""]
    if parser.description:
        lines += ["```text", _wrapped(parser.description), "```", ""]
    rows = [_option_row(parser, a) for a in parser._actions
            if a.help != argparse.SUPPRESS and not isinstance(a, argparse._SubParsersAction)]
    if rows:
        lines += ["| option or argument | takes | help |", "|---|---|---|", *rows, ""]
    sub = _subparsers(parser)
    if sub is not None:
        for name, child in sub.choices.items():
            lines += _section(f"{title} {name}", child, level + 1)
    return lines


def render() -> str:
    """The whole page, from the parser of each command in :data:`COMMAND_HELP`'s order."""
    lines = [HEADER.rstrip("\n")]
    lines += [f"| [`station {name}`](#station-{name}) | {_cell(summary)} |"
              for name, summary in COMMAND_HELP.items()]
    lines.append("")
    for name in COMMAND_HELP:
        sub = _subparsers(build_parser(name))
        assert sub is not None
        lines += _section(f"station {name}", sub.choices[name], 2)
    return "\n".join(lines).rstrip("\n") + "\n"


if __name__ == "__main__":
    PAGE.write_text(render())
    print(f"wrote {PAGE}")
