"""A test sequence in a process of its own: ``station record --sequence``, started detached.

The TUI never runs a sequence in its own process (a night's temperature test outlives the
terminal it was started from): :func:`start_sequence` starts ``python -m
station.commands.record --sequence NAME ...`` detached, as :mod:`station.services.recorder_process`
starts a recorder, into the sequence file the command itself would write (the unfinished
one of the same request when there is one: resumed, exactly as the command resumes it).
Everything else is read from the sequence file (:mod:`station.services.sequence_progress`);
:meth:`SequenceProcess.stop` sends it SIGTERM, a clean stop that leaves it resumable. Its
process id is kept beside the file (``.pid``), so that a TUI opened later follows a
sequence still running (:func:`running_sequence`) instead of resuming it a second time.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

from station.errors import RecorderError, UsageError
from station.model.profiles import load_profile
from station.services.recorder_process import pid_alive
from station.services.sequence import (
    SequenceRequest,
    check_request,
    find_unfinished,
    sequence_path,
)


def sequence_arguments(request: SequenceRequest) -> list[str]:
    """The ``station record`` arguments of ``request`` (how a detached sequence gets it)."""
    args = ["--sequence", request.sequence, "--profile", request.profile,
            "--out", str(request.out), "--quiet"]
    for url in request.units:
        args += ["--unit", url]
    for url in request.power:
        args += ["--power", url]
    for option, value in (("--chamber", request.chamber), ("--operator", request.operator),
                          ("--lot", request.lot), ("--bench", request.bench)):
        if value:
            args += [option, value]
    return args


@dataclass
class SequenceProcess:
    """A sequence process: one this process started, or one found running by its pid file.

    Attributes
    ----------
    path : Path
        Its sequence file.
    log_path : Path
        Where its output goes (beside the sequence file).
    resumed : bool
        Whether it continues an unfinished sequence.
    pid : int
        The process.
    popen : subprocess.Popen or None
        The process when this one started it (None for one found running).
    """

    path: Path
    log_path: Path
    resumed: bool
    pid: int
    popen: subprocess.Popen[bytes] | None = field(default=None, repr=False)

    @property
    def running(self) -> bool:
        """Whether the process still runs (reaps it when it was ours)."""
        if self.popen is not None:
            return self.popen.poll() is None
        return pid_alive(self.pid)

    def exit_code(self) -> int | None:
        """Its exit status when this process started it and it ended (0: every step ran;
        1: it stopped early or failed, the journal says why; 2: the command refused its
        arguments, the log says why); None otherwise."""
        return None if self.popen is None else self.popen.poll()

    def stop(self) -> None:
        """Ask it to stop at once (SIGTERM): the sequence stays resumable."""
        if self.running:
            os.kill(self.pid, signal.SIGTERM)

    def log_tail(self, max_chars: int = 2000) -> str:
        """The end of its output, for a person reading what happened."""
        try:
            return self.log_path.read_text(encoding="utf-8", errors="replace")[-max_chars:]
        except OSError:
            return ""


def start_sequence(request: SequenceRequest) -> SequenceProcess:
    """Check ``request``, then run it (or resume the same sequence left unfinished in
    ``request.out``) in a detached ``station record --sequence`` process; returns at once.

    Raises
    ------
    ProfileError
        No such profile or sequence.
    UsageError
        A request the sequence cannot run with
        (:func:`~station.services.sequence.check_request`), ``request.out`` holds another
        sequence, or the same sequence is running already.
    RecorderError
        The output folder cannot be created.
    """
    import dataclasses

    profile = load_profile(request.profile)
    spec = profile.sequence(request.sequence)
    check_request(request, spec)
    existing = find_unfinished(request.out, spec.name, profile, tuple(request.units))
    live = running_sequence(Path(existing.path)) if existing else None
    if live is not None:
        raise UsageError(f"{live.path.name} is running (pid {live.pid}): follow it, or stop "
                         f"it before starting it again")
    path = Path(existing.path) if existing else sequence_path(request.out, spec.name)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RecorderError(f"cannot create the runs folder {path.parent}: {exc}; choose "
                            f"another folder") from exc
    log_path = path.with_suffix(".log")
    args = sequence_arguments(dataclasses.replace(request, out=path))
    with open(log_path, "ab") as log:
        popen = subprocess.Popen(
            [sys.executable, "-m", "station.commands.record", *args], stdin=subprocess.DEVNULL,
            stdout=log, stderr=subprocess.STDOUT, start_new_session=True, close_fds=True)
    pid_path(path).write_text(str(popen.pid), encoding="utf-8")
    return SequenceProcess(path, log_path, existing is not None, popen.pid, popen)


def pid_path(path: Path) -> Path:
    """Where a sequence started from the TUI keeps its process id (beside its file)."""
    return path.with_suffix(".pid")


def running_sequence(path: Path) -> SequenceProcess | None:
    """The process that runs the sequence file ``path``, when one started by
    :func:`start_sequence` still runs on this machine (None otherwise: ended, killed, or
    started by the command in a terminal, which keeps no pid file). The pid file of a
    process that ended is removed (its number could name another process later)."""
    try:
        pid = int(pid_path(path).read_text(encoding="utf-8").strip())
    except (OSError, ValueError):
        return None
    if not pid_alive(pid):
        pid_path(path).unlink(missing_ok=True)
        return None
    return SequenceProcess(path, path.with_suffix(".log"), True, pid)
