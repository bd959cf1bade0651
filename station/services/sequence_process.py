"""A test sequence in a process of its own: ``station record --sequence``, started detached.

The TUI never runs a sequence in its own process (a night's temperature test outlives the
terminal it was started from): :func:`start_sequence` starts ``python -m
station.commands.record --sequence NAME ...`` detached, as :mod:`station.services.recorder_process`
starts a recorder, into the sequence file the command itself would write (the unfinished
one of the same request when there is one: resumed, exactly as the command resumes it).
Everything else is read from the sequence file (:mod:`station.services.sequence_progress`);
:meth:`SequenceProcess.stop` sends it SIGTERM, a clean stop that leaves it resumable.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

from station.errors import RecorderError
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
    """A sequence this process started.

    Attributes
    ----------
    path : Path
        Its sequence file.
    log_path : Path
        Where its output goes (beside the sequence file).
    resumed : bool
        Whether it continues an unfinished sequence.
    popen : subprocess.Popen
        The process.
    """

    path: Path
    log_path: Path
    resumed: bool
    popen: subprocess.Popen[bytes] = field(repr=False)

    @property
    def running(self) -> bool:
        """Whether the process still runs."""
        return self.popen.poll() is None

    def exit_code(self) -> int | None:
        """Its exit status (0: every step ran; 1: stopped early or failed), None while it
        runs."""
        return self.popen.poll()

    def stop(self) -> None:
        """Ask it to stop at once (SIGTERM): the sequence stays resumable."""
        if self.running and pid_alive(self.popen.pid):
            os.kill(self.popen.pid, signal.SIGTERM)

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
        (:func:`~station.services.sequence.check_request`), or ``request.out`` holds another
        sequence.
    RecorderError
        The output folder cannot be created.
    """
    import dataclasses

    profile = load_profile(request.profile)
    spec = profile.sequence(request.sequence)
    check_request(request, spec)
    existing = find_unfinished(request.out, spec.name, profile, tuple(request.units))
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
    return SequenceProcess(path, log_path, existing is not None, popen)
