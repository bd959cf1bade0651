"""Long records in bounded memory: walking an array a block at a time.

A 24 h run at 1 kHz holds 86.4 million samples per axis, 691 MB in float64: more than an
analysis may hold, let alone its temporaries. The analysis functions that read a whole
record (the Allan sums, the cumulative angle, noise identification, spikes, tones, bias
and bias stability) therefore walk a record longer than :data:`LONG_SAMPLES` in blocks of
:data:`BLOCK_SAMPLES`, and never build a temporary as long as the record. The record
itself may be a numpy memmap (the station writes one from the run file): after each
block, :func:`release` hands the pages of a memory-mapped array back to the operating
system (they stay in its file cache), so the resident memory of the process stays about
one block whatever the length of the record. A shorter record is read as before, in one
piece.

Everything here takes and returns arrays; nothing opens a file.
"""

from __future__ import annotations

import mmap
from collections.abc import Callable, Iterator

import numpy as np
from numpy.typing import NDArray

#: Records longer than this many samples are walked in blocks (8 MB of float64).
LONG_SAMPLES = 1 << 20
#: Samples per block of a long record (2 MB of float64).
BLOCK_SAMPLES = 1 << 18
#: Values gathered at once by :func:`order_statistic` when it narrows its range.
_SELECT_GATHER = 1 << 16
#: Bins per pass of :func:`order_statistic`.
_SELECT_BINS = 1 << 12


def is_long(n_samples: int) -> bool:
    """Whether a record of ``n_samples`` is walked in blocks."""
    return n_samples > LONG_SAMPLES


def spans(start: int, stop: int, block: int | None = None) -> Iterator[tuple[int, int]]:
    """Consecutive ``(a, b)`` ranges of at most ``block`` (default :data:`BLOCK_SAMPLES`)
    covering ``start .. stop - 1``."""
    block = BLOCK_SAMPLES if block is None else block
    for a in range(start, stop, block):
        yield a, min(a + block, stop)


def _mapping(arr: object) -> mmap.mmap | None:
    """The shared memory map behind ``arr`` (a numpy memmap or a view of one), else None."""
    obj: object | None = arr
    while obj is not None:
        mapped = getattr(obj, "_mmap", None)
        if isinstance(mapped, mmap.mmap):
            # mode "c" is a private copy: handing its pages back would drop the edits
            return None if getattr(obj, "mode", None) == "c" else mapped
        obj = getattr(obj, "base", None)
    return None


def is_mapped(arr: object) -> bool:
    """Whether ``arr`` lives in a shared memory map (a numpy memmap or a view of one)."""
    return _mapping(arr) is not None


def release(arr: object) -> None:
    """Hand the resident pages of a memory-mapped array back to the operating system.

    The data stay in the file (and the system's file cache); the next read maps them in
    again. Nothing happens for an array in ordinary memory, a private (copy-on-write)
    mapping, or where the system lacks ``madvise``.
    """
    mapped = _mapping(arr)
    if mapped is not None and hasattr(mapped, "madvise") and hasattr(mmap, "MADV_DONTNEED"):
        try:
            mapped.madvise(mmap.MADV_DONTNEED)
        except (OSError, ValueError):  # a closed map, or a system that refuses
            pass


def decimated(x: NDArray[np.float64], step: int) -> NDArray[np.float64]:
    """``x[::step]`` as a float64 array, read a block at a time: a strided read of a
    memmap maps in every page it strides over (all of them for a step under 512)."""
    if not is_mapped(x):
        return np.asarray(x[::step], dtype=np.float64)
    parts = []
    rows = max(1, BLOCK_SAMPLES // step) * step
    for a, b in spans(0, len(x), rows):
        parts.append(np.array(x[a:b:step], dtype=np.float64))  # a copy, not a view
        release(x)
    return np.concatenate(parts)


def column_sums(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Sum over the first axis of a long array, a block at a time (float64)."""
    total = np.zeros(x.shape[1:])
    for a, b in spans(0, x.shape[0]):
        total += np.asarray(x[a:b], dtype=np.float64).sum(axis=0)
        release(x)
    return total


def first_non_finite(x: NDArray[np.float64]) -> int:
    """Index (along the first axis) of the first row holding a NaN or an infinity; -1 if none."""
    for a, b in spans(0, x.shape[0]):
        bad: NDArray[np.bool_] = ~np.isfinite(np.asarray(x[a:b]))
        release(x)
        if bad.ndim > 1:
            bad = np.asarray(bad.any(axis=tuple(range(1, bad.ndim))), dtype=bool)
        if bad.any():
            return a + int(np.argmax(bad))
    return -1


def order_statistic(
    values: Callable[[int, int], NDArray[np.float64]], n: int, ranks: list[int]
) -> list[float]:
    """Exact order statistics of ``n`` values produced block by block, in bounded memory.

    ``values(a, b)`` returns values ``a .. b - 1`` (it is called again on each pass). The
    range holding the ranks (0-based, ascending) is narrowed by histogram passes until it
    holds at most :data:`_SELECT_GATHER` values (or one distinct value), which are then
    gathered and partitioned: each result is ``np.sort(all)[rank]`` exactly.
    """
    low, high, below = -np.inf, np.inf, 0  # the ranks lie in [low, high]; ``below`` values < low
    while True:
        inside, vmin, vmax = 0, np.inf, -np.inf
        for a, b in spans(0, n):
            v = values(a, b)
            v = v[(v >= low) & (v <= high)]
            if len(v):
                inside += len(v)
                vmin, vmax = min(vmin, float(v.min())), max(vmax, float(v.max()))
        if vmin == vmax:
            return [vmin for _ in ranks]
        if inside <= _SELECT_GATHER:
            parts = []
            for a, b in spans(0, n):
                v = values(a, b)
                parts.append(v[(v >= low) & (v <= high)])
            gathered = np.concatenate(parts)
            at = [r - below for r in ranks]
            return [float(v) for v in np.partition(gathered, at)[at]]
        edges = np.linspace(vmin, vmax, _SELECT_BINS + 1)
        counts = np.zeros(_SELECT_BINS, dtype=np.int64)
        for a, b in spans(0, n):
            v = values(a, b)
            counts += np.histogram(v[(v >= vmin) & (v <= vmax)], bins=edges)[0]
        cum = np.cumsum(counts)
        first = int(np.searchsorted(cum, min(ranks) - below, side="right"))
        last = int(np.searchsorted(cum, max(ranks) - below, side="right"))
        if first != last and len(ranks) > 1:  # ranks far apart: one at a time
            return [order_statistic(values, n, [r])[0] for r in ranks]
        below += int(cum[first - 1]) if first else 0
        low, high = float(edges[first]), float(edges[last + 1])


def median(values: Callable[[int, int], NDArray[np.float64]], n: int) -> float:
    """numpy's median of ``n`` values produced block by block (see :func:`order_statistic`)."""
    if n % 2:
        return order_statistic(values, n, [n // 2])[0]
    a, b = order_statistic(values, n, [n // 2 - 1, n // 2])
    return float(np.mean([a, b]))


def pairwise_sum(x: NDArray[np.float64], start: int = 0, stop: int | None = None, *,
                 nan_as_zero: bool = False) -> float:
    """``np.sum(x[start:stop])`` of a 1-D record, bit for bit, a block at a time.

    numpy sums a contiguous run of float64 pairwise: halves (the first a multiple of 8
    values long) summed apart and added, down to runs of 128. The same halving down to
    runs of :data:`BLOCK_SAMPLES`, each summed by numpy, gives numpy's sum of the whole
    without reading more than a block at once. ``nan_as_zero``: NaN counts as 0 (the sum
    :func:`numpy.nansum` and :func:`numpy.nanmean` take).
    """
    stop = len(x) if stop is None else stop
    n = stop - start
    if n <= BLOCK_SAMPLES:
        v = np.asarray(x[start:stop], dtype=np.float64)
        total = float(np.add.reduce(np.where(np.isnan(v), 0.0, v) if nan_as_zero else v))
        release(x)
        return total
    half = n // 2
    half -= half % 8
    return (pairwise_sum(x, start, start + half, nan_as_zero=nan_as_zero)
            + pairwise_sum(x, start + half, stop, nan_as_zero=nan_as_zero))


def group_means(x: NDArray[np.float64], size: int, count: int) -> NDArray[np.float64]:
    """Means of the first ``count`` consecutive groups of ``size`` samples of a 1-D or 2-D
    record (shape ``(count,)`` or ``(count, k)``), a block of whole groups at a time (a
    group longer than a block of a 1-D record by :func:`pairwise_sum`); each group's mean
    is the one numpy takes of it alone."""
    if x.ndim == 1 and size > BLOCK_SAMPLES:
        return np.array([pairwise_sum(x, g * size, (g + 1) * size) / size for g in range(count)])
    rows = max(1, BLOCK_SAMPLES // size)
    parts = []
    for a, b in spans(0, count, rows):
        chunk = np.asarray(x[a * size : b * size], dtype=np.float64)
        parts.append(chunk.reshape(b - a, size, *x.shape[1:]).mean(axis=1))
        release(x)
    return np.concatenate(parts) if parts else np.zeros((0, *x.shape[1:]))


def nan_mean(x: NDArray[np.float64]) -> float:
    """:func:`numpy.nanmean` of a 1-D record (the mean of the samples that are not NaN),
    bit for bit, a block at a time."""
    count = 0
    for a, b in spans(0, len(x)):
        count += int(np.count_nonzero(~np.isnan(np.asarray(x[a:b]))))
        release(x)
    return pairwise_sum(x, nan_as_zero=True) / count if count else float("nan")


def finite_batch_means(x: NDArray[np.float64], batches: int) -> NDArray[np.float64]:
    """Means of ``batches`` consecutive equal batches of the finite values of a 1-D record
    (``len // batches`` values each, the rest left out), a block at a time.

    Where ``x`` holds no NaN or infinity these are numpy's means bit for bit
    (:func:`group_means`); else the sums run block by block (the same to rounding).
    """
    n = len(x)
    if not any_where(x, lambda v: ~np.isfinite(v)):
        return group_means(x, n // batches, batches)
    count = 0
    for a, b in spans(0, n):
        count += int(np.count_nonzero(np.isfinite(np.asarray(x[a:b]))))
        release(x)
    size = count // batches
    sums = np.zeros(batches)
    seen = 0  # finite values walked so far
    for a, b in spans(0, n):
        v = np.asarray(x[a:b], dtype=np.float64)
        v = v[np.isfinite(v)]
        release(x)
        which = (seen + np.arange(len(v))) // max(size, 1)
        keep = which < batches
        sums += np.bincount(which[keep], weights=v[keep], minlength=batches)[:batches]
        seen += len(v)
    return sums / size if size else np.full(batches, np.nan)


def any_where(
    x: NDArray[np.float64], test: Callable[[NDArray[np.float64]], NDArray[np.bool_]]
) -> bool:
    """Whether ``test`` (elementwise, e.g. ``np.isnan``) holds anywhere in a record, a
    block at a time."""
    for a, b in spans(0, len(x)):
        found = bool(test(np.asarray(x[a:b])).any())
        release(x)
        if found:
            return True
    return False
