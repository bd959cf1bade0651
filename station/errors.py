"""Exceptions of the station layer; each also inherits the builtin that fits."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass


class StationError(Exception):
    """Base class of every error the station raises on purpose; the CLI prints its message."""


class RecordFormatError(StationError, ValueError):
    """A record file (CSV, HDF5) cannot be read as a rate record; the message says why."""


class BenchError(StationError, ValueError):
    """A bench file that cannot be used (unreadable, unknown key, bad latitude or direction)."""


class UsageError(StationError, ValueError):
    """Command-line arguments that do not fit together."""


class ProfileError(StationError, ValueError):
    """A product profile that cannot be used; the message names the file, line and key at fault.

    Attributes
    ----------
    path : str
        The profile file.
    line : int or None
        1-based line of the offending key (None when the fault has no line, e.g. a missing key).
    key : str
        Dotted TOML key at fault (``"figures.arw.limits.navigation"``), "" for the whole file.
    """

    def __init__(
        self, message: str, *, path: str = "", line: int | None = None, key: str = ""
    ) -> None:
        where = path + (f":{line}" if line else "")
        prefix = f"{where}: " if where else ""
        if key:
            prefix += f"key '{key}': "
        super().__init__(prefix + message)
        self.path = path
        self.line = line
        self.key = key


class ResultsDatabaseError(StationError, RuntimeError):
    """The results database cannot be opened, migrated or written."""


class GradingNotStoredError(ResultsDatabaseError):
    """The results database did not take a grading within the time its outage was waited
    for; the grading was shown, and grading the run again stores it (once)."""


class SerialConflictError(ResultsDatabaseError, ValueError):
    """A unit's serial number is another unit's in the results database (another unit of
    the same run, or a unit recorded at the same time in another run): storing its grading
    would let one unit's grading stand for another's, so it is not stored."""


class SequenceError(StationError, RuntimeError):
    """A sequence that cannot go on (a unit that does not turn on, a chamber that does not
    settle, a supply that does not switch); the message says what to fix."""


class RecorderError(StationError, RuntimeError):
    """A recording that cannot start or go on; the message says what to fix.

    ``reason``, where set, is the stop reason it stands for in the run file.
    """

    reason = ""


@dataclass(frozen=True)
class Problem:
    """One reason a run cannot start, with its fix: a unit's (``unit_id``, ``url``) or the
    run's settings' (both "")."""

    text: str
    unit_id: str = ""
    url: str = ""

    def __str__(self) -> str:
        return f"{self.unit_id} ({self.url}): {self.text}" if self.unit_id else self.text


class RunConfigurationError(RecorderError, ValueError):
    """A run refused before it starts: every problem found, each with its fix, on one line
    (``; `` between them: a refusal is one line on stderr).

    Attributes
    ----------
    problems : tuple of Problem
        One per unit or setting at fault.
    """

    def __init__(self, problems: Sequence[Problem | str]) -> None:
        self.problems = tuple(p if isinstance(p, Problem) else Problem(p) for p in problems)
        super().__init__("the run was not started: "
                         + "; ".join(str(p) for p in self.problems))


class DiskSpaceError(RecorderError, OSError):
    """The run's file will not fit on the disk (before the start), or the disk filled up.

    ``reason`` is the run's stop reason it stands for (``disk full: ...``, short enough
    for the run file's stop-reason field).
    """

    reason = "disk full"


class OutputLostError(RecorderError, FileNotFoundError):
    """The run file or its folder was removed while recording (the run stops).

    ``reason`` is the run's stop reason it stands for (``output lost: ...``).
    """

    reason = "output lost"


class RunInProgressError(RecorderError):
    """A run file that a live recorder is still writing (``station recover`` refuses it)."""
