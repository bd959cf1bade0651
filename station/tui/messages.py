"""Errors as the operator reads them: what went wrong and what to do, never a traceback."""

from __future__ import annotations

import errno

from analysis.errors import AnalysisError
from station.errors import StationError


def explain(exc: BaseException, doing: str) -> str:
    """A notification text for ``exc`` raised while ``doing`` (``"grading the run"``).

    Station errors already say what to fix; the others get the fix that fits them.
    """
    if isinstance(exc, StationError | AnalysisError):
        return f"{doing}: {exc}"
    if isinstance(exc, FileNotFoundError):
        return (f"{doing}: no such file {exc.filename or ''}: check the path, or pick the run "
                f"again in Runs (F4)")
    if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        return f"{doing}: the disk is full: free some space or choose another folder"
    if isinstance(exc, PermissionError):
        return f"{doing}: permission denied ({exc.filename or exc}): choose a folder you can write"
    if isinstance(exc, OSError):
        return f"{doing}: {exc.strerror or exc}: check the path and the disk"
    return (f"{doing} failed: {type(exc).__name__}: {exc}. This is a bug of the station: "
            f"please report it with these words")


#: The recorder's command-line words -> the set-up screen's fields.
_FORM_WORDS = (("--profile PROFILE", "a profile (choose one)"), ("--out", "runs folder"),
               ("--duration", "duration"), ("--unit", "unit URL"))


def for_the_form(message: str) -> str:
    """A recorder message with its option names replaced by the set-up screen's fields."""
    for option, field_name in _FORM_WORDS:
        message = message.replace(option, field_name)
    return message
