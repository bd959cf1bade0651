"""Long records kept out of memory while they are evaluated.

A long record (:func:`analysis.allan.blocks.is_long`) read from a run file lives in scratch
memmaps (:mod:`station.storage.mapped_runs`); what the evaluation derives from it whole
(the columns a profile grades, ...) stays a view of them or goes to scratch memmaps too,
written a block at a time.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from analysis.allan import blocks
from station.storage.scratch import scratch_array


def take_columns(rate: NDArray[np.float64], columns: list[int]) -> NDArray[np.float64]:
    """``rate[:, columns]`` of a record (shape (N, k)): an in-memory copy of a short
    record (as numpy takes it); of a long one, a view when the columns are consecutive,
    else a copy in a scratch memmap written a block at a time."""
    if not blocks.is_long(rate.shape[0]):
        return rate[:, columns]
    if columns and columns == list(range(columns[0], columns[0] + len(columns))):
        return rate[:, columns[0] : columns[0] + len(columns)]
    out = scratch_array((len(columns), rate.shape[0]))  # axis-major, as the reader's
    for a, b in blocks.spans(0, rate.shape[0]):
        out[:, a:b] = np.asarray(rate[a:b][:, columns]).T
        blocks.release(rate)
        blocks.release(out)
    return out.T


def angle_buffer(x: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """A scratch memmap for the cumulative angle of a long axis ``x`` (shape (N + 1, 1)),
    for the analysis functions that take ``angle_out``; None for a short axis (its angle
    stays in memory)."""
    return scratch_array((len(x) + 1, 1)) if blocks.is_long(len(x)) else None


@functools.cache
def _malloc_trim() -> Callable[[int], int] | None:
    """glibc's ``malloc_trim`` (None on a C library without it)."""
    name = ctypes.util.find_library("c")
    try:
        trim = ctypes.CDLL(name).malloc_trim if name else None
    except (OSError, AttributeError):
        return None
    if trim is not None:
        trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return trim


def return_freed_heap() -> None:
    """Hand the heap's freed pages back to the system (glibc's ``malloc_trim(0)``; nothing
    elsewhere). Python's allocator frees an axis' blocks into the C heap but glibc keeps
    the pages resident (15-18 MB an axis of a long record, measured); called after each
    axis of a long record, the next axis' peak starts from what is in use."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)
