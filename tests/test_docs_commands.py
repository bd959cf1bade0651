"""Every command of the tutorial (docs/getting-started.md) and the how-to pages is run as the
page writes it, and what it prints (and the files it writes, where the page shows them) is
compared with what the page shows (tests/docs_commands.py says how, tests/docs_pages.py runs
them).

The tutorial records a simulated VG951 for 2 h of simulated time at 200 times real time
(about 36 s of wall time); while it records, the pages that need no run work in folders of
their own, at a lower priority. Then the how-to pages work on its run, in its folder, as they
say they do, all at once (a command two pages write is run once), and a PostgreSQL server
starts for the page that needs one.
"""

from __future__ import annotations

import re
import shutil
import tomllib
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.docs_commands import DOCS, blocks, differences
from tests.docs_pages import ROOT, Folder, Page, PageRun, run_page
from tests.postgres_server import PG_BIN, PostgresServer, running_server

TUTORIAL = "getting-started.md"
#: The how-to pages that need no run: each runs in an empty folder while the tutorial records.
ON_THEIR_OWN = ("how-to/add-a-device-protocol.md", "how-to/write-a-can-layout.md")
#: The how-to pages that work on the tutorial's run, in its folder (the longest first).
ON_THE_TUTORIALS_RUN = ("how-to/export.md", "how-to/grade-a-run.md",
                        "how-to/write-a-spec-sheet.md", "how-to/add-a-profile.md",
                        "how-to/results-postgresql.md")
PAGES = (TUTORIAL, *ON_THEIR_OWN, *ON_THE_TUTORIALS_RUN)
#: The pages that start once the whole tutorial ran (they write its sheet header again, and
#: grade into its results.db); the others start once its run is recorded.
AFTER_THE_TUTORIAL = ("how-to/write-a-spec-sheet.md",)
#: The server port docs/how-to/results-postgresql.md writes; the test's server's stands for it.
PAGE_PORT = "54329"
TOML_BLOCK = re.compile(r"^```toml\n(?P<body>.*?)^```$", re.MULTILINE | re.DOTALL)


def _toml_block(page: str) -> str:
    """The first TOML block of ``page``."""
    found = TOML_BLOCK.search((DOCS / page).read_text())
    assert found is not None, f"{page}: no TOML block"
    return found["body"]


def edit_by_hand(page: str, folder: Path, commands: list[str]) -> None:
    """The edit a page asks for after a ``cp`` of a profile: each ``key = value`` of the
    page's TOML block replaces that key's line in its table of the copied file."""
    copied = folder / commands[-1].split()[-1]
    lines = copied.read_text().splitlines()
    table = ""
    edits: dict[tuple[str, str], str] = {}
    for line in _toml_block(page).splitlines():
        if line.startswith("["):
            table = line
        elif "=" in line:
            edits[(table, line.split("=")[0].strip())] = line
    table = ""
    for i, line in enumerate(lines):
        if line.startswith("["):
            table = line.strip()
        elif "=" in line and (table, line.split("=")[0].strip()) in edits:
            lines[i] = edits.pop((table, line.split("=")[0].strip()))
    assert edits == {}, f"{page}: keys not in {copied.name}: {sorted(edits)}"
    copied.write_text("\n".join(lines) + "\n")


def write_the_layout(page: Page) -> None:
    """The layout file docs/how-to/write-a-can-layout.md writes by hand: its TOML block, which
    it says is the shipped MM7.10 layout's ``[can]`` table, as layouts/MYUNIT.toml."""
    layout = _toml_block(page.name)
    shipped = ROOT / "profiles" / "layouts" / "MM7.10.toml"
    assert tomllib.loads(layout)["can"] == tomllib.loads(shipped.read_text())["can"], \
        f"{page.name}: its layout is not {shipped.name}'s"
    (page.folder.path / "layouts").mkdir()
    (page.folder.path / "layouts" / "MYUNIT.toml").write_text(layout)


def _server(stack: ExitStack, folder: Folder, tutorial: Future[PageRun]) -> PostgresServer | None:
    """A PostgreSQL server for the page that needs one, started once the tutorial's run is
    recorded (not to take the cores from the recording); None where none is installed or
    the tutorial recorded nothing."""
    if not (PG_BIN / "initdb").exists() or not (PG_BIN / "pg_ctl").exists():
        return None
    while not folder.recorded.wait(0.1):
        if tutorial.done():
            return None
    return stack.enter_context(running_server())


def _on_the_server(server: Future[PostgresServer | None]) -> dict[str, str]:
    started = server.result()
    if started is None:
        pytest.skip(f"PostgreSQL server binaries not installed in {PG_BIN} "
                    f"(apt install postgresql-15)")
    return {PAGE_PORT: str(started.port)}


def _run_after(tutorial: Future[PageRun], page: Page, whole_tutorial: bool,
               server: Future[PostgresServer | None] | None = None) -> PageRun:
    """Run ``page`` on the tutorial's run once it is recorded (``whole_tutorial``: once
    every command of the tutorial ran); a failed tutorial fails it."""
    if whole_tutorial:
        tutorial.result()
    while not page.folder.recorded.wait(0.1):
        if tutorial.done():
            tutorial.result()
            raise AssertionError("the tutorial recorded no run")
    if server is not None:
        page.substitutions = _on_the_server(server)
    return run_page(page)


@dataclass(frozen=True)
class Ran:
    """The pages run: each page's run (the commands it ran, or why it failed) and folder."""

    runs: dict[str, Future[PageRun]]
    folders: dict[str, Folder]

    def page(self, name: str) -> tuple[PageRun, Folder]:
        """The page's run (its failure raised here) and its folder."""
        return self.runs[name].result(), self.folders[name]


@pytest.fixture(scope="module")
def ran(tmp_path_factory: pytest.TempPathFactory) -> Ran:
    """Every page run, the how-to pages on the tutorial's run once it is recorded."""
    tutorial = Folder(tmp_path_factory.mktemp("tutorial"))
    shutil.copytree(ROOT / "profiles", tutorial.path / "profiles")
    folders = {name: tutorial for name in (TUTORIAL, *ON_THE_TUTORIALS_RUN)}
    # the pages that need no run give the cores to the tutorial's recording first: a
    # simulated unit not run in time loses its samples
    folders |= {name: Folder(tmp_path_factory.mktemp(Path(name).stem), niceness=10)
                for name in ON_THEIR_OWN}
    with ExitStack() as stack, ThreadPoolExecutor(max_workers=len(PAGES) + 1) as pool:
        runs = {TUTORIAL: pool.submit(run_page, Page(TUTORIAL, tutorial))}
        server = pool.submit(_server, stack, tutorial, runs[TUTORIAL])
        runs |= {name: pool.submit(run_page, Page(
            name, folders[name], before=write_the_layout if "can-layout" in name else None))
            for name in ON_THEIR_OWN}
        for name in ON_THE_TUTORIALS_RUN:
            page = Page(name, tutorial, independent_blocks=name == "how-to/export.md",
                        after_copy=edit_by_hand)
            runs[name] = pool.submit(_run_after, runs[TUTORIAL], page, name in AFTER_THE_TUTORIAL,
                                     server if "postgresql" in name else None)
        for future in runs.values():
            future.exception()
    return Ran(runs, folders)


def test_a_shown_output_matches_the_programs_only_where_they_agree() -> None:
    shown = """\
recording 1 unit(s) to runs/run-20261206T215939Z-9b7aa3a4.h5
  unit1: 33090 samples @10 Hz, newest [+1.5577 -0.2] deg/h
...
station export: note: x: rate random walk is upper bound (1 sigma)...
1 grading
"""
    printed = """\
recording 1 unit(s) to runs/run-20270101T000000Z-0123abcd.h5
  unit1:   120 samples @10 Hz,   newest [-3 +4.25e-05] deg/h
  note: 83 samples missing in gaps after the warm-up: no Allan difference straddles a gap
station export: note: x: rate random walk is upper bound (1 sigma), the record does not resolve K
1 grading
"""
    assert differences(shown, printed) == []
    # a gap note the host's load decides is left out on both sides, wherever it is
    assert differences(shown.replace("\n...\n", "\n"), printed) == []
    # the words are compared, the numbers are not
    for wrong in ("1 gradings", "] deg/s", "lower bound"):
        changed = printed.replace({"1 gradings": "1 grading", "] deg/s": "] deg/h",
                                   "lower bound": "upper bound"}[wrong], wrong)
        assert differences(shown, changed) != [], wrong
    assert differences(shown, printed + "one line more\n") != []
    # a unit the host did not run in time declares a gap: "1 gap" where the page has "0 gaps"
    books = "sim: recorded #, declared missing 0 in 0 gaps, sent 120\n"
    assert differences(books, books.replace("0 in 0 gaps", "3 in 1 gap")) == []
    assert differences(books, books.replace("0 in 0 gaps", "3 in 1 hole")) != []
    # the blocks of a page: a text block right after the commands is their output, a
    # titled block the file of that name
    page = blocks(DOCS / "getting-started.md")
    kalibr = next(b for b in page if "--format kalibr" in b.commands[0])
    assert kalibr.shown is not None and "written to imu.yaml" in kalibr.shown
    assert "gyroscope_noise_density" in kalibr.files["imu.yaml"]
    assert all("--db results.db" in c for b in page for c in b.commands
               if c.startswith(("station grade", "station results", "station report")))


def test_every_how_to_page_runs() -> None:
    how_tos = sorted(p.relative_to(DOCS).as_posix() for p in (DOCS / "how-to").glob("*.md"))
    assert sorted(p for p in PAGES if p.startswith("how-to/")) == how_tos
    for page in PAGES:
        commands = [c for block in blocks(DOCS / page) for c in block.commands]
        assert commands, page
        # one results database throughout a page: every --db names the same one
        assert len({m[1] for c in commands for m in re.finditer(r"--db (\S+)", c)}) <= 1, page


@pytest.mark.slow
def test_the_tutorial_runs_as_written_with_one_database(ran: Ran) -> None:
    done, folder = ran.page(TUTORIAL)
    assert done.ran and done.not_run == [
        "python3 -m venv .venv && . .venv/bin/activate && pip install -e .: "
        "the install: these tests run in the installed checkout"]
    assert sorted(p.name for p in folder.path.glob("*.db")) == ["results.db"]
    assert not (folder.path / "default-data").exists(), \
        "a command of the tutorial wrote the default results database (no --db)"
    folder.skip_if_too_busy()


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if p != TUTORIAL])
def test_a_how_to_page_runs_as_written(page: str, ran: Ran) -> None:
    done, folder = ran.page(page)
    assert done.ran
    assert not (folder.path / "default-data").exists()
    if page == "how-to/write-a-can-layout.md":
        assert len(list(folder.path.glob("runs/*.h5"))) == 1
    if page == "how-to/write-a-spec-sheet.md" and not done.not_run:
        assert (folder.path / "spec-sheet.png").stat().st_size > 0
    folder.skip_if_too_busy()
    optional = [c for c in done.not_run if "not installed here" in c]
    if optional:
        pytest.skip(f"every other command ran and matched its page; not run: {optional}")
