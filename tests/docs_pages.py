"""Running a page's commands as the page writes them, in a folder, and comparing what they
print (and the files they write, where the page shows them) with what the page shows
(tests/docs_commands.py reads the pages and compares; tests/test_docs_commands.py says which
pages run where and in which order).

Several pages run at once in one folder (the how-to pages work on the tutorial's run): a
command a page repeats in the same folder (the tutorial's ``station export ... --format
kalibr``, its sheet header) is run once, and every page that writes it compares what it
printed then; the pages say they work on the tutorial's run, and nothing a repeated command
reads changes in between.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from tests.docs_commands import DOCS, Block, blocks, differences

ROOT = DOCS.parent
#: The recorder's summary of a unit: samples recorded and declared missing.
BOOKS = re.compile(r"recorded (?P<recorded>\d+), declared missing (?P<missing>\d+)")
#: The share of samples a run may lose before its grading changes: the profiles flag a
#: grading for review above 5 % of the run without samples.
BUSY_LOSS = 0.05
#: What a page writes for the checkout's folder; the folder the commands run in stands for it
#: (it gets a copy of the checkout's profiles/).
CHECKOUT = "/path/to/checkout"
#: Commands of the pages that do not run here, and why.
COMMANDS_NOT_RUN = {
    "python3 -m venv .venv && . .venv/bin/activate && pip install -e .":
        "the install: these tests run in the installed checkout",
    "python -m pytest -q -n 0 tests/devices/test_codecs_serial.py "
    "tests/devices/test_conformance.py": "runs tests of this suite",
    "python -m pytest -q -n 0 tests/test_profiles.py": "runs tests of this suite",
}
#: Programs a page may use that are not part of the station: a command of theirs runs where
#: the program is installed and is said as not run where it is not.
OPTIONAL_PROGRAMS = ("pdftoppm",)


def environment(folder: Path) -> dict[str, str]:
    """The environment the pages' commands run in (this checkout's ``station``)."""
    bin_dir = str(Path(sys.executable).parent)
    # (the project's bytecode is compiled once for the suite: tests/conftest.py)
    env = {k: v for k, v in os.environ.items() if k != "STATION_RESULTS_DB"}
    return {**env, "PYTHONPATH": str(ROOT), "PYTHONUNBUFFERED": "1", "COLUMNS": "200",
            "PATH": bin_dir + os.pathsep + env.get("PATH", ""),
            # the database a command without --db would write: it must stay absent
            "XDG_DATA_HOME": str(folder / "default-data")}


def _run(command: str, folder: Path, niceness: int = 0) -> str:
    nice = ["nice", "-n", str(niceness)] if niceness else []
    done = subprocess.run([*nice, "bash", "-c", command], cwd=folder, env=environment(folder),
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=300)
    assert done.returncode == 0, f"{command}\n{done.stdout}"
    return done.stdout


@dataclass
class Folder:
    """The folder pages' commands run in, what its commands printed, and the share of its
    run's samples the simulated unit lost (on a host too busy to run it in warped time)."""

    path: Path
    #: the scheduling niceness of its commands (10: they yield the cores to a recording)
    niceness: int = 0
    lost: float = 0.0
    #: command -> what it printed (a command run again in this folder is not rerun)
    printed: dict[str, Future[str]] = field(default_factory=dict)
    lock: threading.Lock = field(default_factory=threading.Lock)
    #: set once a page's recording here has ended (the run is whole)
    recorded: threading.Event = field(default_factory=threading.Event)

    def books_of(self, printed: str) -> None:
        """Take the share of samples lost from a recorder's summary, ``printed``; the run
        is then whole."""
        books = [(int(m["recorded"]), int(m["missing"])) for m in BOOKS.finditer(printed)]
        assert books, printed
        self.lost = max(missing / (recorded + missing) for recorded, missing in books)
        self.recorded.set()

    @property
    def too_busy(self) -> bool:
        return self.lost > BUSY_LOSS

    def skip_if_too_busy(self) -> None:
        """After every command ran: the outputs after the recording could not be compared."""
        if self.too_busy:
            pytest.skip(f"the host was too busy to reproduce the pages' outputs: the simulated "
                        f"unit lost {self.lost:.0%} of its samples in warped time "
                        f"(more than {BUSY_LOSS:.0%} changes the grading); every command ran "
                        f"and exited 0, their outputs after the recording were not compared")

    def run(self, command: str, substitutions: dict[str, str]) -> str:
        """What ``command`` prints, run here once (a second page's same command waits for it)."""
        with self.lock:
            earlier = self.printed.get(command)
            if earlier is None:
                mine: Future[str] = Future()
                self.printed[command] = mine
        if earlier is not None:
            return earlier.result()
        actual = command
        for old, new in {CHECKOUT: str(self.path), **substitutions}.items():
            actual = actual.replace(old, new)
        try:
            out = _run(actual, self.path, self.niceness)
        except BaseException as failed:
            mine.set_exception(failed)
            raise
        mine.set_result(out)
        return out


@dataclass
class Page:
    """A page to run: where, with which words of the page replaced in its commands (the
    port of a server the test started), what to do before (write a file the page writes by
    hand) and whether its command blocks are independent (they then run at once)."""

    name: str
    folder: Folder
    substitutions: dict[str, str] = field(default_factory=dict)
    before: Callable[[Page], None] | None = None
    #: after a ``cp`` block: the edit the page asks for, by hand, on the copy
    after_copy: Callable[[str, Path, list[str]], None] | None = None
    independent_blocks: bool = False


@dataclass
class PageRun:
    """What running a page did: the commands it ran, and those it did not, with why."""

    ran: list[str] = field(default_factory=list)
    not_run: list[str] = field(default_factory=list)


def _watch_while_recording(command: str, folder: Path,
                           recorder: subprocess.Popen[str]) -> str:
    """What ``command`` (a ``station watch``) prints once the recorder has flushed samples,
    while it still records (what a person sees from another terminal)."""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and recorder.poll() is None:
        if list(folder.glob("runs/*.h5")):
            out = subprocess.run(["bash", "-c", command], cwd=folder,
                                 env=environment(folder), capture_output=True, text=True)
            if out.returncode == 0 and ": recording," in out.stdout \
                    and " 0 samples" not in out.stdout:
                return out.stdout + out.stderr
        time.sleep(0.2)
    raise AssertionError(f"{command}: the recording ended before it showed samples")


def check(block: Block, printed: str, folder: Path, page: str, compare: bool = True) -> None:
    """Compare what ``block``'s commands printed, and the files it shows, with the page."""
    # the pages shorten the checkout's paths (profiles/VG951.toml)
    printed = printed.replace(f"{ROOT}/", "").replace(str(folder), CHECKOUT)
    for name in block.files:
        assert (folder / name).exists(), f"{page}: no file {name}"
    if not compare:
        return
    if block.shown is not None:
        diff = differences(block.shown, printed)
        assert diff == [], "\n".join([f"{page}: {' ; '.join(block.commands)}", *diff])
    for name, shown in block.files.items():
        diff = differences(shown, (folder / name).read_text())
        assert diff == [], "\n".join([f"{page}: the file {name}", *diff])


def _finish_recording(recorder: tuple[subprocess.Popen[str], Block], at: Folder,
                      page: str) -> None:
    process, record_block = recorder
    out, _ = process.communicate(timeout=600)
    assert process.returncode == 0, out
    at.books_of(out)
    check(record_block, out, at.path, page)


def _not_run_here(command: str) -> str | None:
    if command in COMMANDS_NOT_RUN:
        return COMMANDS_NOT_RUN[command]
    program = command.split()[0]
    if program in OPTIONAL_PROGRAMS and shutil.which(program) is None:
        return f"{program} is not installed here"
    return None


def run_page(page: Page) -> PageRun:
    """Run the page's commands in its folder and compare their outputs. A ``station
    record`` followed by a ``station watch`` runs in the background while the watch follows
    it, as the tutorial says ("from another terminal")."""
    at = page.folder
    done = PageRun()
    if page.before is not None:
        page.before(page)
    page_blocks = blocks(DOCS / page.name)
    for block in page_blocks:
        skipped = [(c, why) for c in block.commands if (why := _not_run_here(c)) is not None]
        done.not_run += [f"{c}: {why}" for c, why in skipped]
    runnable = [(block, [c for c in block.commands if _not_run_here(c) is None])
                for block in page_blocks]
    runnable = [(block, commands) for block, commands in runnable if commands]

    def run_block(block: Block, commands: list[str]) -> None:
        printed = "".join(at.run(command, page.substitutions) for command in commands)
        check(block, printed, at.path, page.name, compare=not at.too_busy)
        done.ran.extend(commands)
        if page.after_copy is not None and commands[-1].startswith("cp "):
            page.after_copy(page.name, at.path, commands)

    if page.independent_blocks:
        with ThreadPoolExecutor(max_workers=len(runnable) or 1) as pool:
            for future in [pool.submit(run_block, *item) for item in runnable]:
                future.result()
        return done
    recorder: tuple[subprocess.Popen[str], Block] | None = None
    for i, (block, commands) in enumerate(runnable):
        following = runnable[i + 1][1][0] if i + 1 < len(runnable) else ""
        if commands[0].startswith("station record") and len(commands) == 1 \
                and following.startswith("station watch"):
            process = subprocess.Popen(["bash", "-c", commands[0]], cwd=at.path,
                                       env=environment(at.path), stdout=subprocess.PIPE,
                                       stderr=subprocess.STDOUT, text=True)
            recorder = (process, block)
            done.ran += commands
            continue
        if recorder is not None and commands[0].startswith("station watch"):
            check(block, _watch_while_recording(commands[0], at.path, recorder[0]),
                  at.path, page.name)
            done.ran += commands
            _finish_recording(recorder, at, page.name)  # the next command reads the run
            recorder = None
            continue
        run_block(block, commands)
        if commands[0].startswith("station record"):
            at.books_of(at.printed[commands[0]].result())
    return done
