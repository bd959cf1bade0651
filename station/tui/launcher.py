"""Starting, finding, stopping and probing recorder processes for the TUI.

The recorder never runs inside the TUI: :func:`start_recorder` starts ``python -m
station.commands.record`` as a detached process (its own session, stdin closed, output
to a log file beside the run file), so that closing or crashing the TUI never stops an
overnight run. Everything else the TUI knows about a run it reads from the run file:
:func:`find_active_runs` lists the files whose recorder is still alive (``writer_pid``,
``station_host`` and the ``run_state`` row), :func:`stop_run` sends that recorder SIGTERM
(a clean stop, as Ctrl-C on ``station record``), and :func:`probe_units` checks that each
unit answers by recording a fraction of a second with the real recorder, in a process of
its own: the TUI process itself never opens a device.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

from station.errors import RecorderError, StationError
from station.storage.hdf5 import open_run_file, run_state, text_value, unit_ids

#: Simulated seconds (or real seconds for hardware) a unit check records.
PROBE_DURATION_S = 0.2
#: Longest wait for a unit check, s (wall): opening a real device can take a while.
PROBE_TIMEOUT_S = 90.0
#: Run files looked at, newest first, when searching for a run in progress.
MAX_RUNS_SCANNED = 50


class RecorderStartError(RecorderError):
    """The recorder process ended before its run file appeared; the message is its own."""


@dataclass(frozen=True)
class RunRequest:
    """What the set-up screen asks the recorder for (the arguments of ``station record``).

    Attributes
    ----------
    urls : tuple of str
        Device URLs, one per unit.
    duration : str
        Run length as the operator typed it (``12h``, ``90s``), parsed by the recorder.
    out_dir : Path
        Folder the run file goes into.
    profile : str or None
        Profile name or TOML path (None: simulated units only).
    operator, lot : str
        Run metadata.
    """

    urls: tuple[str, ...]
    duration: str
    out_dir: Path
    profile: str | None = None
    operator: str = ""
    lot: str = ""


@dataclass
class RecorderProcess:
    """A recorder started by this TUI (``popen`` is None for one found by its run file)."""

    path: Path
    log_path: Path
    pid: int
    popen: subprocess.Popen[bytes] | None = field(default=None, repr=False)

    def exit_code(self) -> int | None:
        """The process's exit code, None while it runs (reaps it when it was ours)."""
        if self.popen is not None:
            return self.popen.poll()
        return None if pid_alive(self.pid) else 0

    def log_tail(self, max_chars: int = 2000) -> str:
        """The end of the recorder's output (its error message when it refused to start)."""
        try:
            return self.log_path.read_text(encoding="utf-8", errors="replace")[-max_chars:]
        except OSError:
            return ""


def recorder_arguments(request: RunRequest, path: Path) -> list[str]:
    """The ``station record`` arguments of a request, recording into ``path``."""
    args = ["--out", str(path), "--duration", request.duration, "--quiet"]
    if request.profile:
        args += ["--profile", request.profile]
    for url in request.urls:
        args += ["--unit", url]
    if request.operator:
        args += ["--operator", request.operator]
    if request.lot:
        args += ["--lot", request.lot]
    return args


def new_run_path(out_dir: Path) -> Path:
    """A new run file name in ``out_dir`` (the recorder's own pattern)."""
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    return out_dir / f"run-{stamp}-{uuid.uuid4().hex[:8]}.h5"


def _spawn(args: Sequence[str], log_path: Path, *, cwd: Path | None = None
           ) -> subprocess.Popen[bytes]:
    with open(log_path, "ab") as log:
        return subprocess.Popen(
            [sys.executable, "-m", "station.commands.record", *args], stdin=subprocess.DEVNULL,
            stdout=log, stderr=subprocess.STDOUT, cwd=cwd, start_new_session=True,
            close_fds=True)


def start_recorder(request: RunRequest) -> RecorderProcess:
    """Start the recorder for ``request`` as a detached process; returns at once.

    Raises
    ------
    RecorderError
        The output folder cannot be created.
    """
    try:
        request.out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RecorderError(f"cannot create the runs folder {request.out_dir}: {exc}; choose "
                            f"another folder") from exc
    path = new_run_path(request.out_dir)
    log_path = path.with_suffix(".log")
    popen = _spawn(recorder_arguments(request, path), log_path)
    return RecorderProcess(path, log_path, popen.pid, popen)


def recorder_message(log: str) -> str:
    """The recorder's error message from its output, as the set-up screen words it
    (without the ``station record: error:`` prefix, with the form's field names)."""
    lines = [ln for ln in log.strip().splitlines() if ln.strip()]
    for i, line in enumerate(lines):
        if "error:" in line:
            first = line.split("error:", 1)[1].strip()
            rest = [ln.strip() for ln in [first, *lines[i + 1:]]]
            return for_the_form("\n".join(ln for ln in rest if ln and ln != _NOT_STARTED))
    return lines[-1] if lines else "the recorder ended without a message"


_NOT_STARTED = "the run was not started:"
#: The recorder's command-line words -> the set-up screen's fields.
_FORM_WORDS = (("--profile PROFILE", "a profile (choose one)"), ("--out", "runs folder"),
               ("--duration", "duration"), ("--unit", "unit URL"))


def for_the_form(message: str) -> str:
    """A recorder message with its option names replaced by the set-up screen's fields."""
    for option, field_name in _FORM_WORDS:
        message = message.replace(option, field_name)
    return message


def wait_for_run_file(process: RecorderProcess, timeout_s: float = 120.0,
                      poll_s: float = 0.1, *,
                      cancelled: Callable[[], bool] = lambda: False) -> Path:
    """Wait until the recorder's run file can be read (every unit described); give up
    (the recorder goes on) when ``cancelled()`` turns true.

    Raises
    ------
    RecorderStartError
        The recorder ended first (the message says why: bad URL, no answer, disk...).
    RecorderError
        Nothing within ``timeout_s`` (wall s).
    """
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and not cancelled():
        if process.path.exists() and _readable(process.path):
            return process.path
        code = process.exit_code()
        if code is not None:
            if process.path.exists() and _readable(process.path):
                return process.path
            raise RecorderStartError(recorder_message(process.log_tail()))
        time.sleep(poll_s)
    raise RecorderError(f"the recorder (pid {process.pid}) wrote no run file in {timeout_s:g} s; "
                        f"see {process.log_path}")


def _readable(path: Path) -> bool:
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


@dataclass(frozen=True)
class RunFileState:
    """What a run file says about its recorder."""

    path: Path
    state: str
    writer_pid: int
    writer_here: bool
    stop_reason: str

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
    return RunFileState(path, state["state"], pid, host == socket.gethostname(),
                        state["stop_reason"])


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


def probe_message(message: str, url: str) -> str:
    """The recorder's refusal of one probed unit (from :func:`recorder_message`) without
    the unit's name and URL: the set-up screen shows them beside it."""
    prefix = f"unit1 ({url}): "
    return "\n".join(ln.strip().removeprefix(prefix) for ln in message.splitlines())


@dataclass(frozen=True)
class ProbeResult:
    """The outcome of checking one unit: its description, or what is wrong and what to do."""

    url: str
    ok: bool
    model: str = ""
    serial_number: str = ""
    sample_rate_hz: float = 0.0
    axes: tuple[str, ...] = ()
    message: str = ""

    @property
    def summary(self) -> str:
        """One line for the units table."""
        if not self.ok:
            return f"no: {self.message.splitlines()[0] if self.message else 'no answer'}"
        model = Path(self.model).stem if "/" in self.model else self.model
        return (f"ok: {model} {self.serial_number or '-'}, {self.sample_rate_hz:g} Hz, "
                f"{len(self.axes)} ax")


def probe_unit(url: str, profile: str | None = None, *,
               timeout_s: float = PROBE_TIMEOUT_S) -> ProbeResult:
    """Check that one unit answers: record :data:`PROBE_DURATION_S` of it in a recorder
    process of its own, then read what it said about itself from the file (deleted)."""
    with tempfile.TemporaryDirectory(prefix="station-probe-") as tmp:
        path = Path(tmp) / "probe.h5"
        args = ["--out", str(path), "--duration", f"{PROBE_DURATION_S:g}", "--quiet",
                "--json-summary", "--unit", url]
        if profile:
            args += ["--profile", profile]
        log_path = Path(tmp) / "probe.log"
        popen = _spawn(args, log_path)
        try:
            popen.wait(timeout_s)
        except subprocess.TimeoutExpired:
            os.killpg(popen.pid, signal.SIGKILL)
            popen.wait()
            return ProbeResult(url, False, message=f"no answer within {timeout_s:g} s: check "
                                                   f"that the device is powered and connected")
        log = log_path.read_text(encoding="utf-8", errors="replace")
        if popen.returncode != 0 or not path.exists():
            return ProbeResult(url, False, message=probe_message(recorder_message(log), url))
        with open_run_file(path) as f:
            attrs = f["units"][unit_ids(f)[0]].attrs
            return ProbeResult(url, True, text_value(attrs["model"]),
                               text_value(attrs["serial_number"]),
                               float(attrs["sample_rate_hz"]),
                               tuple(json.loads(text_value(attrs["axes"]))))
