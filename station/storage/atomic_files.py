"""Writing an output file whole or not at all: a temporary file beside it, then a rename."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from station.errors import UsageError


def write_text_atomically(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file in the same folder.

    The temporary file is flushed to disk and renamed over ``path`` (``os.replace``,
    atomic on one file system), so a reader sees the old file or the whole new one, and
    a crash or a full disk leaves no partial output behind.

    Raises
    ------
    UsageError
        The folder does not exist or cannot be written; ``path`` is a folder.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise UsageError(f"{path} is a folder: give a file name to write")
    if not folder.is_dir():
        raise UsageError(f"no folder {folder} to write {path.name} into: create it first")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise UsageError(f"cannot write into {folder}: {exc.strerror}") from exc
    try:
        os.fchmod(fd, 0o644)  # mkstemp's 0600 would hide the output from other users
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise UsageError(f"cannot write {path}: {exc.strerror or exc}") from exc
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return path
