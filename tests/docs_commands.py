"""The commands of the tutorial and the how-to pages, read from the pages, and the outputs the
pages show beside them, compared with what the program prints (tests/test_docs_commands.py).

A page's `` ```sh `` block holds commands, one a line. The block right after it, when it is a
`` ```text `` block, shows what those commands print (stdout and stderr as a terminal shows
them); a block with a title (`` ```yaml title="imu.yaml" ``) shows the file of that name
the commands before it wrote.

A shown output is compared line by line with the program's, after :func:`normalized`: the
run's name, time stamps and every number are placeholders (they change from run to run and
with the host), and whitespace is collapsed. A line ``...`` (``# ...``, ``% ...`` in a file) stands
for any number of lines; a line ending in ``...`` matches every line that starts with what is
before it. Lines that only the host's load decides are left out on both sides
(:data:`HOST_LINES`): a simulated unit at 200 times real time loses the samples it cannot
send while the host does not run it, and the recorder declares them as gaps, so the gap
notes of the grading, the review they may raise and the readings of a fit the gapped record
leaves open (``AMBIGUOUS``) come and go with the machine's load.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1] / "docs"

#: `` ```lang attributes `` ... `` ``` `` at the start of a line
FENCE = re.compile(r"^```(?P<lang>[\w-]*)(?P<attrs>[^\n]*)\n(?P<body>.*?)^```[ \t]*$",
                   re.MULTILINE | re.DOTALL)
TITLE = re.compile(r'title="(?P<title>[^"]+)"')
HEREDOC = re.compile(r"<<-?\s*'?(?P<word>[A-Za-z_]+)'?\s*$")

#: What changes from run to run: the run's name, UTC time stamps, numbers.
VOLATILE = (
    (re.compile(r"\d{8}T\d{6}Z-[0-9a-f]{8}"), "RUN"),
    (re.compile(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(?:\.\d+)?Z?"), "UTC"),
    (re.compile(r"\d\d:\d\d:\d\d"), "HH:MM:SS"),
    (re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?k?"), "#"),
    # how many gaps the host's load makes decides the noun's number: "0 gaps", "1 gap"
    (re.compile(r"# gaps?\b"), "# gaps"),
    # the review flag the gaps may raise: at the end of a unit's line, in the results' column
    (re.compile(r"\s+REVIEW$"), ""),
    (re.compile(r"\bREVIEW\b"), "-"),
)
#: Lines that come and go with the host's load (see the module's docstring).
HOST_LINES = re.compile(
    r"^(?:note: # samples missing in gaps|gaps: #|(?:review #:|-) record: .*no sample"
    r"|AMBIGUOUS )")


@dataclass
class Block:
    """A command block of a page and what the page shows of its outputs."""

    commands: list[str]
    #: the shown terminal output of the commands (None: the page shows none)
    shown: str | None = None
    #: file name -> its shown content, for files the page shows after these commands
    files: dict[str, str] = field(default_factory=dict)


def _commands(body: str) -> list[str]:
    """A shell block's commands, one a line (a line ending in a backslash continues; a
    here-document, ``cat > f <<'EOF'`` to its ``EOF`` line, is one command)."""
    out: list[str] = []
    lines = body.replace("\\\n", " ").splitlines()
    i = 0
    while i < len(lines):
        line = lines[i].strip()
        here = HEREDOC.search(line)
        if here:
            end = next((j for j in range(i + 1, len(lines))
                        if lines[j].strip() == here["word"]), len(lines) - 1)
            out.append("\n".join([line, *lines[i + 1:end + 1]]))
            i = end + 1
            continue
        if line:
            out.append(line)
        i += 1
    return out


def blocks(page: Path) -> list[Block]:
    """The page's command blocks, each with the outputs shown after it."""
    text = page.read_text()
    found: list[Block] = []
    end = 0
    for fence in FENCE.finditer(text):
        adjacent = text[end:fence.start()].strip() == ""
        end = fence.end()
        title = TITLE.search(fence["attrs"])
        if fence["lang"] == "sh":
            found.append(Block(_commands(fence["body"])))
        elif found and title:
            found[-1].files[title["title"]] = fence["body"]
        elif found and adjacent and fence["lang"] == "text" and found[-1].shown is None:
            found[-1].shown = fence["body"]
    return found


def normalized(line: str) -> str:
    """``line`` with its volatile parts as placeholders and its whitespace collapsed."""
    for pattern, placeholder in VOLATILE:
        line = pattern.sub(placeholder, line)
    return " ".join(line.split())


def _comparable(text: str) -> list[str]:
    lines = [normalized(line) for line in text.splitlines()]
    return [line for line in lines if line and not HOST_LINES.match(line)]


def _is_gap(line: str) -> bool:
    return line in ("...", "# ...", "% ...")


def _matches(shown: str, actual: str) -> bool:
    if shown.endswith("...") and not _is_gap(shown):
        return actual.startswith(shown[:-3].rstrip())
    return shown == actual


def differences(shown: str, actual: str) -> list[str]:
    """Where ``actual`` (the program's output) departs from ``shown`` (the page's), as
    lines to print; empty when they agree."""
    want, got = _comparable(shown), _comparable(actual)

    def match(i: int, j: int) -> bool:
        if i == len(want):
            return j == len(got)
        if _is_gap(want[i]):
            return any(match(i + 1, k) for k in range(j, len(got) + 1))
        return j < len(got) and _matches(want[i], got[j]) and match(i + 1, j + 1)

    if match(0, 0):
        return []
    return ["the page shows (normalized):", *want, "the program printed (normalized):", *got]
