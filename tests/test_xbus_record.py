"""``station record`` of Xsens MTi streams: the real MTi-G-710 capture served on a pty
(GNSS messages between the samples, a healthy StatusWord), a simulated MTi-G, and a unit
configured without its rate of turn (refused, exit 2, naming the item)."""

from __future__ import annotations

import contextlib
import errno
import json
import os
import subprocess
import threading
import time
import tty
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from station.storage.hdf5 import open_run_file, read_unit
from tests.test_recorder_helpers import (
    assert_summary_books,
    run_station,
    station_cmd,
    summaries,
)

CAPTURE = (Path(__file__).resolve().parents[2] / "shared" / "real-captures" / "xsens-mtig710"
           / "1" / "output.bin")
#: GoToConfig, GoToMeasurement and their acknowledgements (MID + 1), from the document.
COMMANDS = {bytes.fromhex("faff3000d1"): bytes.fromhex("faff3100d0"),
            bytes.fromhex("faff1000f1"): bytes.fromhex("faff1100f0")}
#: A profile of a three-axis unit at 100 Hz (what the capture's unit sent).
PROFILE = "ADIS16405"


def _messages(data: bytes) -> list[bytes]:
    """Split a capture of short-form Xbus messages (FA FF MID LEN data CS)."""
    out, pos = [], 0
    while pos < len(data):
        n = 5 + data[pos + 3]
        out.append(data[pos:pos + n])
        pos += n
    return out


@contextlib.contextmanager
def served_on_a_pty(messages: list[bytes], period_s: float = 0.01) -> Iterator[str]:
    """A unit on a pty: it answers GoToConfig / GoToMeasurement as the document says and,
    once measuring, sends ``messages`` one per ``period_s`` (then nothing). Yields the
    port's path."""
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    stop = threading.Event()

    def unit() -> None:
        commands, measuring, pending = b"", False, list(messages)
        while not stop.is_set():
            with contextlib.suppress(BlockingIOError, OSError):
                os.set_blocking(master, False)
                commands += os.read(master, 4096)
            for command, ack in COMMANDS.items():
                if command in commands:
                    commands = commands.replace(command, b"", 1)
                    os.write(master, ack)
                    measuring = command[2] == 0x10
            if measuring and pending:
                _write_all(master, pending.pop(0), stop)
            stop.wait(period_s)

    thread = threading.Thread(target=unit, name="pty-mti", daemon=True)
    thread.start()
    try:
        yield os.ttyname(slave)
    finally:
        stop.set()
        thread.join(5.0)
        os.close(master)
        os.close(slave)


def _write_all(fd: int, data: bytes, stop: threading.Event) -> None:
    """Write all of ``data`` (a port that is not read yet holds the unit back: a capture
    is sent whole, never cut)."""
    os.set_blocking(fd, False)
    while data and not stop.is_set():
        try:
            data = data[os.write(fd, data):]
        except OSError as exc:
            if exc.errno != errno.EAGAIN:
                raise
            time.sleep(0.005)


@pytest.mark.skipif(not CAPTURE.is_file(), reason=f"the real MTi-G-710 capture is not at "
                                                  f"{CAPTURE}")
def test_recording_the_real_capture_gives_valid_samples_and_no_false_gap(
        tmp_path: Path) -> None:
    """96 samples of the 100 messages (4 are GNSS PVT data), none missing, every status 0
    (the unit's StatusWord 0x5 / 0x1800005 / 0x1800045 / 0x1800007 is a healthy one)."""
    out = tmp_path / "mti.h5"
    with served_on_a_pty(_messages(CAPTURE.read_bytes())) as port:
        done = run_station("record", "--profile", PROFILE, "--unit",
                           f"serial://{port}?protocol=xbus&rate=100", "--duration", "3",
                           "--json-summary", "--out", str(out), timeout_s=120.0)
    assert done.returncode == 0, done.stderr
    (summary,) = summaries(done.stdout)
    assert (summary["samples_recorded"], summary["samples_missing_declared"],
            summary["gaps"]) == (96, 0, 0)
    with open_run_file(out) as f:
        unit = read_unit(f, "unit1")
        np.testing.assert_array_equal(np.diff(unit.counter), 1)
        assert not np.any(unit.status)


@pytest.mark.skipif(not CAPTURE.is_file(), reason=f"the real MTi-G-710 capture is not at "
                                                  f"{CAPTURE}")
def test_the_json_summary_ends_the_output_with_stderr_merged(tmp_path: Path) -> None:
    """``station record --json-summary 2>&1 | tail -1`` is the unit's summary: the CPU report
    (stderr) comes before it. The real capture replayed: 96 samples, none missing."""
    done = subprocess.run(
        station_cmd("record", "--profile", PROFILE, "--unit",
                    f"replay://{CAPTURE}?protocol=xbus&rate=100", "--duration", "60",
                    "--json-summary", "--out", str(tmp_path / "mti.h5")),
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120.0, check=False)
    assert done.returncode == 0, done.stdout
    lines = done.stdout.strip().splitlines()
    assert any("of a core" in line for line in lines[:-1]), done.stdout
    last = json.loads(lines[-1])
    assert (last["samples_recorded"], last["samples_missing_declared"]) == (96, 0)


def test_a_simulated_mti_g_records_with_exact_books(tmp_path: Path) -> None:
    """GNSS messages at 4 Hz between the 200 Hz samples: what the simulator sent is what
    was recorded plus what was declared missing, and every sample is valid."""
    out = tmp_path / "sim.h5"
    url = "sim+serial://MTI-630?protocol=xbus&rate=200&warp=4&seed=2&gnss=4"
    done = run_station("record", "--unit", url, "--duration", "4", "--json-summary",
                       "--out", str(out), timeout_s=120.0)
    assert done.returncode == 0, done.stderr
    (summary,) = summaries(done.stdout)
    assert_summary_books(summary)
    assert summary["samples_sent"] == summary["samples_recorded"] + \
        summary["samples_missing_declared"]
    with open_run_file(out) as f:
        assert not np.any(read_unit(f, "unit1").status)


def test_a_unit_sending_no_rate_of_turn_is_refused_naming_it(tmp_path: Path) -> None:
    """MTData2 messages with a PacketCounter and SampleTimeFine only: exit 2, and the one
    line about the unit names RateOfTurn (0x8020) and what to change."""
    messages = []
    for counter in range(200):
        data = (bytes.fromhex("102002") + counter.to_bytes(2, "big")
                + bytes.fromhex("106004") + (counter * 100).to_bytes(4, "big"))
        body = bytes([0xFF, 0x36, len(data)]) + data
        messages.append(b"\xfa" + body + bytes([(-sum(body)) & 0xFF]))
    with served_on_a_pty(messages) as port:
        done = run_station("record", "--profile", PROFILE, "--unit",
                           f"serial://{port}?protocol=xbus&rate=100", "--duration", "5",
                           "--out", str(tmp_path / "none.h5"), timeout_s=120.0)
    assert done.returncode == 2
    about_unit = [line for line in done.stderr.splitlines() if "unit1" in line]
    assert len(about_unit) == 1 and "Traceback" not in done.stderr
    assert "carry no RateOfTurn (0x8020)" in about_unit[0] and "hr=1" in about_unit[0]
    assert not (tmp_path / "none.h5").exists()
