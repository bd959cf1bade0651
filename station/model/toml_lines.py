"""Where each key of a TOML text sits: the line a profile error names (``tomllib`` parses
the values but keeps no positions)."""

from __future__ import annotations

import re

_HEADER_RE = re.compile(r"^\s*\[\[?\s*([^\]]+?)\s*\]\]?\s*(#.*)?$")
_KEY_RE = re.compile(r"^\s*([A-Za-z0-9_\-\"'. ]+?)\s*=")


def _split_key(text: str) -> tuple[str, ...]:
    return tuple(part.strip().strip("\"'") for part in text.split("."))


def key_lines(text: str) -> dict[tuple[str, ...], int]:
    """1-based line of every table header and ``key =`` line, by dotted key path.

    A key inside an inline table has no line of its own: a caller looks it up by its
    longest prefix that has one, the inline table's.
    """
    lines: dict[tuple[str, ...], int] = {}
    table: tuple[str, ...] = ()
    for number, raw in enumerate(text.splitlines(), start=1):
        header = _HEADER_RE.match(raw)
        if header and "=" not in raw.split("#")[0].split("]")[0]:
            table = _split_key(header.group(1))
            lines.setdefault(table, number)
            continue
        key = _KEY_RE.match(raw)
        if key:
            lines.setdefault(table + _split_key(key.group(1)), number)
    return lines
