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
import sys
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
    release_compiler_pages()


#: Shared libraries whose code pages :func:`release_compiler_pages` drops from the resident
#: set: llvmlite's (numba's compiler, a 170 MB library of which loading and compiling the
#: kernels touches 40-70 MB).
COMPILER_LIBRARIES = ("libllvmlite",)
#: ``madvise``'s MADV_DONTNEED (Linux).
_MADV_DONTNEED = 4


@functools.cache
def _madvise() -> Callable[[int, int, int], int] | None:
    """The C library's ``madvise`` (None off Linux or without it)."""
    name = ctypes.util.find_library("c")
    if not sys.platform.startswith("linux") or not name:
        return None
    try:
        advise = ctypes.CDLL(name, use_errno=True).madvise
    except (OSError, AttributeError):
        return None
    advise.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
    advise.restype = ctypes.c_int
    return advise


def _clean_library_ranges(names: tuple[str, ...]) -> list[tuple[int, int]]:
    """(start, end) of the read-only mappings of the libraries ``names`` that hold no
    private (copy-on-write) page: their pages are the file's, read again from the page
    cache when touched (``/proc/self/smaps``)."""
    ranges, current = [], None
    with open("/proc/self/smaps") as smaps:
        for line in smaps:
            head = line.split(maxsplit=6)
            if "-" in head[0] and not head[0].endswith(":"):  # a mapping's first line
                path = head[5] if len(head) > 5 else ""
                start, end = (int(v, 16) for v in head[0].split("-"))
                current = None
                if "w" not in head[1] and any(n in path for n in names):
                    current = (start, end)
            elif head[0] == "Anonymous:" and current is not None:
                if int(head[1]) == 0:
                    ranges.append(current)
                current = None
    return ranges


def release_compiler_pages() -> None:
    """Drop numba's compiler library's code pages from the process' resident set
    (``madvise(MADV_DONTNEED)`` on its read-only mappings without private pages; nothing
    when numba was not loaded or off Linux). Those pages are the library file's, shared
    with the page cache: calling the compiled kernels does not touch them (their machine
    code is in the JIT's own memory), a later compilation reads them in again. Compiling
    and loading the kernels leaves 40-70 MB of them resident for the rest of the process."""
    if "llvmlite" not in sys.modules:
        return
    advise = _madvise()
    if advise is None:
        return
    try:
        ranges = _clean_library_ranges(COMPILER_LIBRARIES)
    except OSError:
        return
    for start, end in ranges:
        advise(start, end - start, _MADV_DONTNEED)
