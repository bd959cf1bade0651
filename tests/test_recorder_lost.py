"""Faults of a production day, each on a real recorder process: the output folder removed,
the disk full on a real small file system, a unit's device (its process) lost mid-run, and
the recorder killed (``station watch`` and the TUI's live screen say it is gone).

Each run that a fault stops ends with exit status 3 (not 2, refused input) and one line
that says what happened, what the file kept (samples per unit up to its last flush, the
file) and what to do; the file, where it still exists, reads.
"""

from __future__ import annotations

import asyncio
import contextlib
import io
import json
import os
import shutil
import signal
import subprocess
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from station.cli import main
from station.commands.watch import status_json
from station.services.record import EXIT_RUN_FAULT
from station.services.recorder_process import run_file_state
from station.storage.hdf5 import read_run
from tests.test_recorder_helpers import (
    check_unit_against_signal,
    child_pids,
    start_recorder,
    wait_for_samples,
)

URL = "sim+serial://STIM300?protocol=xbus&rate=500&seed={seed}"
FLUSH_S = 0.5


def _fault_line(stderr: str) -> str:
    lines = [line for line in stderr.splitlines() if not line.startswith("recording ")]
    assert len(lines) == 1 and "Traceback" not in stderr, stderr  # one line, no traceback
    return lines[0]


@contextlib.contextmanager
def _small_file_system(folder: Path, size: str) -> Iterator[str]:
    """A tmpfs of ``size`` mounted on ``folder`` ("tmpfs"), or, where this process may not
    mount one, nothing ("file size limit": the caller lowers the recorder's RLIMIT_FSIZE
    instead, the same failed write with EFBIG instead of ENOSPC)."""
    folder.mkdir(parents=True)
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs",
                              str(folder)], capture_output=True, check=False).returncode == 0
    try:
        yield "tmpfs" if mounted else "file size limit"
    finally:
        if mounted:
            subprocess.run(["umount", "-l", str(folder)], check=False)


def _fill(folder: Path) -> None:
    """Another program fills the file system of ``folder``."""
    with open(folder / "filler", "wb") as fh:
        with contextlib.suppress(OSError):
            while True:
                fh.write(b"\0" * (1 << 20))


@pytest.fixture(scope="module")
def faults() -> Iterator[dict[str, tuple]]:
    """Four recorders started at once, each hit by its fault once it has committed
    samples: (return code, stdout, stderr, run file, url, extra)."""
    with tempfile.TemporaryDirectory() as tmp, \
            _small_file_system(Path(tmp) / "small", "16m") as how:
        root = Path(tmp)
        folders = {"folder removed": root / "removed" / "out", "device lost": root / "device",
                   "disk full": root / "small", "killed": root / "killed"}
        procs = {}
        for i, (name, folder) in enumerate(folders.items()):
            url = URL.format(seed=40 + i)
            # no reserve (a write fails), and a run that fits the small disk at its start
            extra = ["--reserve-mb", "0"] if name == "disk full" else []
            duration = "30s" if name == "disk full" else "1h"
            procs[name] = (start_recorder("--unit", url, "--duration", duration, "--out",
                                          str(folder), "--quiet", "--flush-interval",
                                          str(FLUSH_S), *extra), url)
        out: dict[str, tuple] = {}
        try:
            paths = {name: wait_for_samples(folders[name], 100, timeout_s=240.0)
                     for name in folders}  # (a loaded host starts recorders slowly)
            live = status_json(paths["killed"])  # before the kill: recording, not gone
            os.kill(procs["killed"][0].pid, signal.SIGKILL)
            shutil.rmtree(folders["folder removed"])
            for server in child_pids(procs["device lost"][0].pid):  # the forkserver's
                for unit in child_pids(server):  # children: the unit's process
                    os.kill(unit, signal.SIGKILL)
            if how == "tmpfs":
                _fill(folders["disk full"])
            else:
                import resource
                limit = paths["disk full"].stat().st_size + 60_000
                resource.prlimit(procs["disk full"][0].pid, resource.RLIMIT_FSIZE,
                                 (limit, limit))
            for name, (proc, url) in procs.items():
                stdout, stderr = proc.communicate(timeout=120)
                out[name] = (proc.returncode, stdout, stderr, paths[name], url,
                             live if name == "killed" else how)
            yield out
        finally:
            for proc, _ in procs.values():
                if proc.poll() is None:
                    proc.kill()
                    proc.communicate()


@pytest.mark.slow
def test_a_removed_output_folder_stops_the_run_saying_what_was_lost(faults) -> None:
    code, _, stderr, path, _, _ = faults["folder removed"]
    assert code == EXIT_RUN_FAULT, stderr
    line = _fault_line(stderr)
    assert f"the output folder {path.parent} was removed while recording" in line, line
    assert "unit1 " in line and " samples" in line and "is lost" in line, line
    assert "no such file" not in line  # not the wording of a mistyped argument


def test_a_full_small_file_system_stops_the_run_with_the_file_readable(faults) -> None:
    code, _, stderr, path, url, how = faults["disk full"]
    assert code == EXIT_RUN_FAULT, stderr
    line = _fault_line(stderr)
    assert "disk full" in line, (how, line)
    n = read_run(path).units[0].record.n_samples
    assert f"{path} keeps every sample up to its last flush" in line
    assert f"unit1 {n} samples" in line, line
    assert f"station recover {path}" in line, line  # the write failed: the file needs closing
    assert check_unit_against_signal(path, "unit1", url) == n  # every committed row intact
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["recover", str(path)]) == 0
    assert read_run(path).units[0].record.n_samples == n
    print(f"disk full ({how}): {n} samples kept: {line[:120]}")


def test_a_lost_device_stops_its_unit_with_the_reason_in_the_closed_file(faults) -> None:
    code, _, stderr, path, url, _ = faults["device lost"]
    assert code == EXIT_RUN_FAULT, stderr
    line = _fault_line(stderr)
    run = read_run(path)
    n = run.units[0].record.n_samples
    assert run.stop_reason.startswith("device lost: unit1 (its process "), run.stop_reason
    assert run_file_state(path).state == "stopped"  # closed: nothing to recover
    assert "unit1 ended on an error" in line and f"unit1 {n} samples" in line, line
    assert f"{path} keeps every sample" in line and "the file is closed" in line, line
    assert check_unit_against_signal(path, "unit1", url) == n


def _gone_path(faults) -> Path:
    path = faults["killed"][3]
    deadline = time.monotonic() + 30.0
    while not run_file_state(path).recorder_gone() and time.monotonic() < deadline:
        time.sleep(0.1)
    return path


def test_watch_says_when_the_recorder_is_gone_and_what_to_do(
        faults, capsys: pytest.CaptureFixture[str]) -> None:
    live = faults["killed"][5]
    assert live["state"] == "recording" and live["recorder_gone"] is False
    assert live["advice"] is None and live["last_flush_age_s"] < 30.0
    path = _gone_path(faults)
    assert main(["watch", str(path), "--once"]) == EXIT_RUN_FAULT
    out = capsys.readouterr().out
    assert "RECORDER GONE" in out and f"station recover {path}" in out, out
    assert main(["watch", str(path), "--json"]) == EXIT_RUN_FAULT  # ends by itself
    doc = json.loads(capsys.readouterr().out)
    assert doc["state"] == "recording" and doc["recorder_gone"] is True
    assert doc["last_flush_age_s"] > FLUSH_S + 2.0
    assert f"station recover {path}" in doc["advice"]
    st = run_file_state(path)
    assert not st.recorder_gone(margin_s=doc["last_flush_age_s"] + 60.0)  # not yet overdue


def test_the_live_screen_says_when_the_recorder_is_gone(faults, tmp_path: Path) -> None:
    from station.tui.app import StationApp, TuiSettings
    from station.tui.live_screen import LiveScreen
    from tests.test_tui import SIZE, screen_text, until

    path = _gone_path(faults)

    async def scenario() -> tuple[str, str]:
        app = StationApp(TuiSettings(runs_dir=tmp_path, reports_dir=tmp_path / "reports",
                                     db_path=tmp_path / "results.sqlite", check_units=False,
                                     poll_s=0.2))
        async with app.run_test(size=SIZE) as pilot:
            screen = LiveScreen(path, poll_s=0.2)
            app.push_screen(screen)
            await until(pilot, lambda: bool(screen.recorder_gone), 20, "the gone recorder")
            return screen_text(app), screen.recorder_gone

    text, advice = asyncio.run(scenario())
    # the title names the run; the status line what to do, and the folder it is in
    assert f"Live: {path.name}" in text, text
    assert f"recorder gone: run `station recover` in {path.parent}" in text, text
    assert advice.startswith("the recorder is gone (pid")  # what its notice says in full
    assert f"station recover {path}" in advice
