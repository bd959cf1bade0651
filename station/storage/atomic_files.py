"""Writing an output file whole or not at all: a temporary file beside it, then a rename."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from station.errors import UsageError


@contextlib.contextmanager
def replacing(path: str | Path) -> Iterator[Path]:
    """A temporary file beside ``path`` (same folder, same suffix) for the block to write;
    when the block ends without an exception it is flushed to disk and renamed over
    ``path`` (``os.replace``, atomic on one file system), else removed: a reader sees the
    old file or the whole new one, and a failure or a crash leaves the old file as it was.
    A ``path`` that is not a regular file (``/dev/null``, ``/dev/stdout``, a pipe) is
    written in place: renaming over it would replace the device with a file.

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
    if path.exists() and not path.is_file():  # a device or a pipe: no file to replace
        yield path
        return
    try:
        fd, name = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix or ".tmp",
                                    dir=folder)
    except OSError as exc:
        raise UsageError(f"cannot write into {folder}: {exc.strerror}") from exc
    tmp = Path(name)
    try:
        os.fchmod(fd, 0o644)  # mkstemp's 0600 would hide the output from other users
        os.close(fd)
        yield tmp
        with tmp.open("rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise UsageError(f"cannot write {path}: {exc.strerror or exc}") from exc
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def write_text_atomically(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file in the same folder
    (:func:`replacing`).

    Raises
    ------
    UsageError
        The folder does not exist or cannot be written; ``path`` is a folder.
    """
    path = Path(path)
    with replacing(path) as tmp, tmp.open("w", encoding="utf-8", newline="\n") as f:
        f.write(text)
    return path
