"""Recorders in processes of their own: starting one detached, finding, following and
stopping the runs in progress from their files.

The TUI never records in its own process: :func:`start_recording` starts ``python -m
station.commands.record`` detached (its own session, stdin closed, output to a log file
beside the run file), so that closing or crashing the TUI never stops an overnight run.
The recorder keeps a status document (:class:`~station.services.record.RecorderStatus`)
that says it records, or why it refused to start, unit by unit. Everything else is read
from the run file: :func:`find_active_runs` lists the files whose recorder is still alive
(``writer_pid``, ``station_host`` and the ``run_state`` row), :func:`stop_run` sends that
recorder SIGTERM (a clean stop, as Ctrl-C on ``station record``).
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import socket
import subprocess
import sys
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from devices.protocols import DeviceDescription
from station.errors import Problem, RecorderError, StationError
from station.model.documents import utc_seconds
from station.recording.recorder import run_file_path
from station.services.record import (
    RecorderStatus,
    RecordRequest,
    read_status,
    recorder_arguments,
)
from station.storage.hdf5 import open_run_file, run_state, text_value, unit_ids

#: Run files looked at, newest first, when searching for a run in progress.
MAX_RUNS_SCANNED = 50
#: Longest wait for a unit check, s (wall): opening a real device can take a while.
CHECK_TIMEOUT_S = 90.0


class RecorderStartError(RecorderError):
    """The recorder refused the run or ended before its run file appeared.

    Attributes
    ----------
    problems : tuple of Problem
        What it found wrong, unit by unit (its status document).
    """

    def __init__(self, problems: Sequence[Problem]) -> None:
        self.problems = tuple(problems)
        super().__init__("; ".join(str(p) for p in self.problems))


@dataclass
class RecorderProcess:
    """A recorder this process started (``popen`` is None for one found by its run file)."""

    path: Path
    log_path: Path
    pid: int
    popen: subprocess.Popen[bytes] | None = field(default=None, repr=False)

    @property
    def status_path(self) -> Path:
        """Where the recorder keeps its status document."""
        return self.path.with_suffix(".status.json")

    def status(self) -> RecorderStatus | None:
        """The recorder's status document, None before it wrote one."""
        return read_status(self.status_path)

    def exit_code(self) -> int | None:
        """The process's exit code, None while it runs (reaps it when it was ours)."""
        if self.popen is not None:
            return self.popen.poll()
        return None if pid_alive(self.pid) else 0

    def log_tail(self, max_chars: int = 2000) -> str:
        """The end of the recorder's output, for a person reading what happened."""
        try:
            return self.log_path.read_text(encoding="utf-8", errors="replace")[-max_chars:]
        except OSError:
            return ""


def _spawn(args: Sequence[str], log_path: Path) -> subprocess.Popen[bytes]:
    with open(log_path, "ab") as log:
        return subprocess.Popen(
            [sys.executable, "-m", "station.commands.record", *args], stdin=subprocess.DEVNULL,
            stdout=log, stderr=subprocess.STDOUT, start_new_session=True, close_fds=True)


def start_recording(request: RecordRequest) -> RecorderProcess:
    """Start the recorder for ``request`` as a detached process, into a new run file in
    the folder ``request.out``; returns at once.

    Raises
    ------
    RecorderError
        The output folder cannot be created.
    """
    try:
        request.out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RecorderError(f"cannot create the runs folder {request.out}: {exc}; choose "
                            f"another folder") from exc
    path = run_file_path(request.out, uuid.uuid4().hex)
    process = RecorderProcess(path, path.with_suffix(".log"), 0)
    args = [*recorder_arguments(dataclasses.replace(request, out=path)),
            "--status", str(process.status_path)]
    popen = _spawn(args, process.log_path)
    process.pid, process.popen = popen.pid, popen
    return process


@dataclass(frozen=True)
class UnitCheck:
    """Whether one unit answers: its description, or what is wrong and what to do."""

    url: str
    ok: bool
    description: DeviceDescription | None = None
    message: str = ""


def check_unit(url: str, profile: str | None = None, *,
               timeout_s: float = CHECK_TIMEOUT_S) -> UnitCheck:
    """Check that one unit answers, in a recorder process of its own (``station record
    --check``: it opens the unit, checks it against the profile, waits for its first
    sample and releases it, writing nothing), and read its status document."""
    args = ["--check", "--unit", url, "--duration", "1s"]
    if profile:
        args += ["--profile", profile]
    proc = subprocess.Popen([sys.executable, "-m", "station.commands.record", *args],
                            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        return UnitCheck(url, False, message=f"no answer within {timeout_s:g} s: check that "
                                             f"the device is powered and connected")
    try:
        status = RecorderStatus.from_json(json.loads(out.decode("utf-8", "replace")))
    except ValueError:
        return UnitCheck(url, False, message=f"the unit check ended (exit status "
                                             f"{proc.returncode}) without a status")
    if status.state == "checked" and status.units:
        return UnitCheck(url, True, status.units[0])
    return UnitCheck(url, False, message="\n".join(p.text for p in status.problems))


def wait_for_run_file(process: RecorderProcess, timeout_s: float = 120.0,
                      poll_s: float = 0.1, *,
                      cancelled: Callable[[], bool] = lambda: False) -> Path:
    """Wait until the recorder records and its run file can be read (every unit
    described); give up (the recorder goes on) when ``cancelled()`` turns true.

    Raises
    ------
    RecorderStartError
        The recorder refused the run (its status says why, unit by unit) or ended first.
    RecorderError
        Nothing within ``timeout_s`` (wall s).
    """
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and not cancelled():
        _raise_if_refused(process)
        if _readable(process.path):
            return process.path
        code = process.exit_code()
        if code is not None:
            _raise_if_refused(process)
            if _readable(process.path):
                return process.path
            raise RecorderStartError((Problem(
                f"the recorder ended (exit status {code}) before its run file appeared; see "
                f"{process.log_path}"),))
        time.sleep(poll_s)
    raise RecorderError(f"the recorder (pid {process.pid}) wrote no run file in {timeout_s:g} s; "
                        f"see {process.log_path}")


def _raise_if_refused(process: RecorderProcess) -> None:
    """Raise the recorder's refusal once its status says it refused (after it exits)."""
    status = process.status()
    if status is None or status.state not in ("refused", "error"):
        return
    if process.popen is not None:
        try:
            process.popen.wait(10.0)  # it exits right after saying so
        except subprocess.TimeoutExpired:
            pass
    raise RecorderStartError(status.problems)


def _readable(path: Path) -> bool:
    if not path.exists():
        return False
    try:
        with open_run_file(path) as f:
            ids = unit_ids(f)
            return bool(ids) and all(uid in f["units"] for uid in ids)
    except (OSError, StationError, KeyError):
        return False


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` runs on this machine (a zombie counts as ended)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return True
    return stat.rsplit(")", 1)[-1].split()[0] != "Z"


#: How far past its flush interval a run file's last flush may lag, s, before a reader
#: that also finds the writer's process gone says that the recorder is gone.
GONE_MARGIN_S = 2.0
#: The flush interval assumed for a file that does not record its own (the longest
#: allowed), s.
LONGEST_FLUSH_INTERVAL_S = 1.0


@dataclass(frozen=True)
class RunFileState:
    """What a run file says about its recorder: its state, the writer's pid and host,
    when it last flushed and how often it flushes."""

    path: Path
    state: str
    writer_pid: int
    writer_here: bool
    stop_reason: str
    station_host: str = ""
    last_flush_utc: str = ""
    flush_interval_s: float = LONGEST_FLUSH_INTERVAL_S

    def flush_age_s(self, now_s: float | None = None) -> float | None:
        """Seconds since the last flush (``now_s`` a ``time.time()``), None before one."""
        flushed = utc_seconds(self.last_flush_utc)
        return None if flushed is None else (time.time() if now_s is None else now_s) - flushed

    def recorder_gone(self, *, margin_s: float = GONE_MARGIN_S,
                      now_s: float | None = None) -> bool:
        """Recording, no flush for longer than the flush interval plus ``margin_s``, and
        the writer's process absent from this station (a recorder on another station:
        False, that cannot be told from here)."""
        age = self.flush_age_s(now_s)
        return (self.state == "recording" and self.writer_here
                and age is not None and age > self.flush_interval_s + margin_s
                and not pid_alive(self.writer_pid))

    def gone_advice(self, now_s: float | None = None) -> str:
        """What the operator reads when :meth:`recorder_gone`: what happened, what is
        safe and what to do."""
        age = self.flush_age_s(now_s) or 0.0
        return (f"the recorder is gone (pid {self.writer_pid} on {self.station_host} is not "
                f"running, no flush for {age:.0f} s): the data up to its last flush "
                f"({self.last_flush_utc}) are safe; run `station recover {self.path}` to "
                f"close the file, then record the rest again")

    @property
    def recording(self) -> bool:
        """The file is open for writing and its recorder is alive on this station."""
        return self.state == "recording" and self.writer_here and pid_alive(self.writer_pid)

    @property
    def abandoned(self) -> bool:
        """Never closed, and its recorder is gone (killed): ``station recover`` closes it."""
        return self.state == "recording" and self.writer_here and not pid_alive(self.writer_pid)


def run_file_state(path: Path) -> RunFileState:
    """The recorder state a run file records.

    Raises
    ------
    RecordFormatError
        Not a run file.
    """
    with open_run_file(path) as f:
        state = run_state(f)
        pid = int(f.attrs.get("writer_pid", -1))
        host = text_value(f.attrs.get("station_host", ""))
        interval = float(f.attrs.get("flush_interval_s", LONGEST_FLUSH_INTERVAL_S))
    return RunFileState(path, state["state"], pid, host == socket.gethostname(),
                        state["stop_reason"], host, state["last_flush_utc"], interval)


def find_active_runs(runs_dir: Path) -> list[Path]:
    """Run files in ``runs_dir`` (newest first) whose recorder is still recording."""
    if not runs_dir.is_dir():
        return []
    files = sorted(runs_dir.glob("*.h5"), key=lambda p: p.stat().st_mtime, reverse=True)
    active = []
    for path in files[:MAX_RUNS_SCANNED]:
        try:
            if run_file_state(path).recording:
                active.append(path)
        except (OSError, StationError, KeyError):
            continue
    return active


def stop_run(path: Path) -> int:
    """Ask the recorder writing ``path`` to stop cleanly (SIGTERM); returns its pid.

    Raises
    ------
    RecorderError
        The run is not recording, or its recorder runs on another station.
    """
    st = run_file_state(path)
    if st.state != "recording":
        raise RecorderError(f"{path.name} is not recording (it stopped: {st.stop_reason})")
    if not st.writer_here:
        raise RecorderError(f"{path.name} is recorded by another station: stop it there")
    if not pid_alive(st.writer_pid):
        raise RecorderError(f"the recorder of {path.name} is gone (killed?): run "
                            f"`station recover {path}` to close the file")
    os.kill(st.writer_pid, signal.SIGTERM)
    return st.writer_pid
