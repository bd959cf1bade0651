"""Scratch arrays on disk: a long record's rate and angle outside the process's memory.

A 24 h run at 1 kHz holds 691 MB per axis in float64. The analysis of such a run keeps
its rate and cumulative angle in numpy memmaps of files in the temporary directory
(``TMPDIR``, which should be on a disk, not in memory): the analysis reads them a block
at a time and hands their pages back (:mod:`analysis.allan.blocks`), so the process's memory
stays bounded. Each file is unlinked as soon as it is mapped, so nothing is left behind
however the process ends; its space is reserved up front, so a full disk is a one-line
error, not a crash while writing.
"""

from __future__ import annotations

import os
import tempfile

import numpy as np

from station.errors import StationError


class ScratchSpaceError(StationError, OSError):
    """No room in the temporary directory for a long record's scratch arrays."""


def scratch_array(shape: tuple[int, ...], dtype: type | np.dtype = np.float64) -> np.memmap:
    """A zeroed array of ``shape`` backed by an unlinked temporary file (a writable memmap).

    Raises
    ------
    ScratchSpaceError
        The temporary directory lacks the room (the message names it and the size).
    """
    size = max(int(np.prod(shape, dtype=np.int64)) * np.dtype(dtype).itemsize, 1)
    directory = tempfile.gettempdir()
    fd, path = tempfile.mkstemp(prefix="gyro-station-", suffix=".scratch", dir=directory)
    try:
        try:
            os.posix_fallocate(fd, 0, size)
        except OSError as exc:
            raise ScratchSpaceError(
                f"no room for {size / 1e6:.0f} MB of scratch space in {directory} "
                f"({exc.strerror}); free some or point TMPDIR at a disk with room"
            ) from None
        return np.memmap(path, dtype=dtype, mode="r+", shape=shape)
    finally:
        os.close(fd)
        os.unlink(path)
