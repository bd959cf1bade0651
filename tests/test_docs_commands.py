"""Every command of the tutorial (docs/getting-started.md) and the how-to pages is run as the
page writes it, in an empty folder, and what it prints (and the files it writes, where the
page shows them) is compared with what the page shows (tests/docs_commands.py says how).

The tutorial records a simulated VG951 for 2 h of simulated time at 200 times real time
(about 36 s of wall time, 12 s of CPU); the how-to pages then work on its run, in the same
folder, as they say they do.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.docs_commands import DOCS, Block, blocks, differences

ROOT = DOCS.parent
#: The recorder's summary of a unit: samples recorded and declared missing.
BOOKS = re.compile(r"recorded (?P<recorded>\d+), declared missing (?P<missing>\d+)")
#: The share of samples a run may lose before its grading changes: the profiles flag a
#: grading for review above 5 % of the run without samples.
BUSY_LOSS = 0.05

#: The pages whose commands run here, in this order, in one folder.
PAGES = ("getting-started.md", "how-to/grade-a-run.md", "how-to/export.md",
         "how-to/add-a-device-protocol.md", "how-to/add-a-profile.md")
#: What a page writes for the checkout's folder; the folder the commands run in stands for it
#: (it gets a copy of the checkout's profiles/).
CHECKOUT = "/path/to/checkout"
#: The how-to pages whose commands do not run here, and why.
PAGES_NOT_RUN = {
    "how-to/write-a-can-layout.md": "its layout file is written by hand in its first steps",
    "how-to/write-a-spec-sheet.md": "its last steps simulate 12 h and render the README's "
                                    "picture with pdftoppm; its header steps are the "
                                    "tutorial's step 5, which runs",
    "how-to/results-postgresql.md": "it needs a PostgreSQL server with a 'station' role "
                                    "(tests/test_results_postgres.py covers the storage)",
}
#: Commands of the run pages that do not run here, and why.
COMMANDS_NOT_RUN = {
    "python3 -m venv .venv && . .venv/bin/activate && pip install -e .":
        "the install: these tests run in the installed checkout",
    "python -m pytest -q -n 0 tests/devices/test_codecs_serial.py "
    "tests/devices/test_conformance.py": "runs tests of this suite",
    "python -m pytest -q -n 0 tests/test_profiles.py": "runs tests of this suite",
}
TOML_BLOCK = re.compile(r"^```toml\n(?P<body>.*?)^```$", re.MULTILINE | re.DOTALL)


def edit_by_hand(page: str, folder: Path, commands: list[str]) -> None:
    """The edit a page asks for after a ``cp`` of a profile: each ``key = value`` of the
    page's TOML block replaces that key's line in its table of the copied file."""
    copied = folder / commands[-1].split()[-1]
    lines = copied.read_text().splitlines()
    table = ""
    edits: dict[tuple[str, str], str] = {}
    for line in TOML_BLOCK.search((DOCS / page).read_text())["body"].splitlines():  # type: ignore[index]
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


def _environment(folder: Path) -> dict[str, str]:
    bin_dir = str(Path(sys.executable).parent)
    env = {k: v for k, v in os.environ.items() if k != "STATION_RESULTS_DB"}
    return {**env, "PYTHONPATH": str(ROOT), "PYTHONUNBUFFERED": "1", "COLUMNS": "200",
            "PATH": bin_dir + os.pathsep + env.get("PATH", ""),
            # the database a command without --db would write: it must stay absent
            "XDG_DATA_HOME": str(folder / "default-data")}


def _run(command: str, folder: Path) -> str:
    done = subprocess.run(["bash", "-c", command], cwd=folder, env=_environment(folder),
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=300)
    assert done.returncode == 0, f"{command}\n{done.stdout}"
    return done.stdout


def _watch_while_recording(command: str, folder: Path,
                           recorder: subprocess.Popen[str]) -> str:
    """What ``command`` (a ``station watch``) prints once the recorder has flushed samples,
    while it still records (what a person sees from another terminal)."""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and recorder.poll() is None:
        if list(folder.glob("runs/*.h5")):
            out = subprocess.run(["bash", "-c", command], cwd=folder,
                                 env=_environment(folder), capture_output=True, text=True)
            if out.returncode == 0 and ": recording," in out.stdout \
                    and " 0 samples" not in out.stdout:
                return out.stdout + out.stderr
        time.sleep(0.2)
    raise AssertionError(f"{command}: the recording ended before it showed samples")


def _check(block: Block, printed: str, folder: Path, page: str, compare: bool = True) -> None:
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


@dataclass
class Folder:
    """The folder the pages' commands run in, and the share of its run's samples the
    simulated unit lost (on a host too busy to run it at 200 times real time)."""

    path: Path
    lost: float = 0.0

    @property
    def too_busy(self) -> bool:
        return self.lost > BUSY_LOSS

    def skip_if_too_busy(self) -> None:
        """After every command ran: the outputs after the recording could not be compared."""
        if self.too_busy:
            pytest.skip(f"the host was too busy to reproduce the pages' outputs: the simulated "
                        f"unit lost {self.lost:.0%} of its samples at 200 times real time "
                        f"(more than {BUSY_LOSS:.0%} changes the grading); every command ran "
                        f"and exited 0, their outputs after the recording were not compared")


def run_page(page: str, at: Folder) -> list[str]:
    """Run the page's commands in ``at`` and compare their outputs; returns the commands
    run. A ``station record`` runs in the background while a ``station watch`` right after
    it follows it, as the tutorial says ("from another terminal")."""
    folder = at.path
    ran: list[str] = []
    recorder: tuple[subprocess.Popen[str], Block] | None = None
    for block in blocks(DOCS / page):
        commands = [c for c in block.commands if c not in COMMANDS_NOT_RUN]
        if not commands:
            continue
        if commands[0].startswith("station record") and len(commands) == 1:
            process = subprocess.Popen(["bash", "-c", commands[0]], cwd=folder,
                                       env=_environment(folder), stdout=subprocess.PIPE,
                                       stderr=subprocess.STDOUT, text=True)
            recorder = (process, block)
            ran += commands
            continue
        if recorder is not None and commands[0].startswith("station watch"):
            printed = _watch_while_recording(commands[0], folder, recorder[0])
            _check(block, printed, folder, page)
            ran += commands
            continue
        if recorder is not None:  # the next command reads the finished run
            process, record_block = recorder
            out, _ = process.communicate(timeout=600)
            assert process.returncode == 0, out
            _check(record_block, out, folder, page)
            books = [(int(m["recorded"]), int(m["missing"])) for m in BOOKS.finditer(out)]
            assert books, out
            at.lost = max(missing / (recorded + missing) for recorded, missing in books)
            recorder = None
        printed = "".join(_run(command.replace(CHECKOUT, str(folder)), folder)
                          for command in commands)
        _check(block, printed, folder, page, compare=not at.too_busy)
        ran += commands
        if commands[-1].startswith("cp profiles/"):
            edit_by_hand(page, folder, commands)
    assert recorder is None, f"{page}: nothing reads the recording it starts"
    return ran


@pytest.fixture(scope="module")
def tutorial_folder(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Folder]:
    """The folder the tutorial's commands ran in (its run, results.db, sheets/, imu.yaml)."""
    folder = Folder(tmp_path_factory.mktemp("tutorial"))
    shutil.copytree(ROOT / "profiles", folder.path / "profiles")
    assert run_page("getting-started.md", folder)
    yield folder


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
    # the blocks of a page: a text block right after the commands is their output, a
    # titled block the file of that name
    page = blocks(DOCS / "getting-started.md")
    kalibr = next(b for b in page if "--format kalibr" in b.commands[0])
    assert kalibr.shown is not None and "written to imu.yaml" in kalibr.shown
    assert "gyroscope_noise_density" in kalibr.files["imu.yaml"]
    assert all("--db results.db" in c for b in page for c in b.commands
               if c.startswith(("station grade", "station results", "station report")))


def test_every_command_of_the_how_to_pages_is_run_or_said_why_not() -> None:
    how_tos = sorted(p.relative_to(DOCS).as_posix() for p in (DOCS / "how-to").glob("*.md"))
    assert sorted([p for p in PAGES if p.startswith("how-to/")] + list(PAGES_NOT_RUN)) \
        == how_tos
    for page in PAGES:
        assert any(block.commands for block in blocks(DOCS / page)), page


@pytest.mark.slow
def test_the_tutorial_runs_as_written_with_one_database(tutorial_folder: Folder) -> None:
    assert sorted(p.name for p in tutorial_folder.path.glob("*.db")) == ["results.db"]
    assert not (tutorial_folder.path / "default-data").exists(), \
        "a command of the tutorial wrote the default results database (no --db)"
    tutorial_folder.skip_if_too_busy()


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if p != "getting-started.md"])
def test_a_how_to_page_runs_as_written_on_the_tutorials_run(
        page: str, tutorial_folder: Folder) -> None:
    assert run_page(page, tutorial_folder)
    assert not (tutorial_folder.path / "default-data").exists()
    tutorial_folder.skip_if_too_busy()
