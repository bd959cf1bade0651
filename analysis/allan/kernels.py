"""Inner loops of the Allan family: sums of squared second differences of the angle.

Two quantities are needed over and over:

* the overlapping Allan sum of a whole record, ``sum_n Delta_m(n)^2`` with
  ``Delta_m(n) = theta[n+2m] - 2 theta[n+m] + theta[n]`` (Zhang 2015, eq. 5), per m;
* the same sum over sliding windows of ``L = Nw + 1 - 2m`` terms (the DAVAR of
  Zhang 2015, eq. 6 and 15), per window start and m.

Each has a pure-numpy implementation (always available, what the tests compare against)
and a compiled one (numba, a dependency of the default install) that fuses the second
difference, the square and the sum into one pass over ``theta`` and spreads the m values
over the cores; the results agree to rounding (about 1e-15 relative). ``backend="auto"``
takes the compiled one when numba can be imported and the work is large
(:data:`COMPILED_MIN_TERMS`; :data:`COMPILED_MIN_WINDOW_TERMS` for the DAVAR): numba's
import and the load of its cached kernels cost 0.6-1.1 s on this machine, more than the
compiled kernels save on a short record (a one-hour CSV analyses as fast in numpy as with
that start-up). The choice depends on the
work alone, never on what the process ran before, so the same record gives the same
numbers in any process (a fleet worker and the command line agree to the last bit).

Precision of the window sums: a window sum taken as the difference of two entries of one
float64 running sum over the whole record loses about ``1e-16 N / L`` relative. None of
the kernels here does that:

* steps of at least 1/32 of the window (both kernels): the window edges cut the terms
  into segments, each summed once, and a window adds up its segments (no subtraction);
* numpy, shorter steps: the terms are cut into blocks of ``L`` terms; a window starting
  at offset ``r`` of block ``q`` is the suffix sum of block ``q`` from ``r`` plus the
  prefix sum of block ``q + 1`` up to ``r``: two sums of non-negative terms added, no
  subtraction, so the relative error stays near ``1e-16 L`` at worst whatever N is. The
  numpy kernels walk the terms a chunk at a time (never a record-long array per m);
* compiled, shorter steps: the window slides by adding the entering and subtracting the
  leaving terms in a Neumaier-compensated sum, which keeps ~1e-16 of the current sum.
"""

from __future__ import annotations

import threading
from functools import lru_cache
from types import ModuleType
from typing import Literal

import numpy as np
from numpy.typing import NDArray

import analysis.allan.blocks as blocks

Backend = Literal["auto", "numpy", "numba"]

#: Samples per block of the numpy overlapping kernel: 2 x 32 k doubles stay in L2.
_NUMPY_BLOCK = 1 << 15
#: Terms per block of a memory-mapped record's compiled overlapping sums (one m at a time:
#: three ranges of 2 MB of the angle, then handed back).
_LONG_BLOCK = 1 << 18
#: Blocks of the long numpy kernel between two hand-backs of a memory-mapped angle.
_RELEASE_EVERY = 8
#: Up to this many window starts per window length, the compiled DAVAR kernel sums the
#: segments between window edges; beyond, it slides a compensated running sum.
_SEGMENTS_MAX_OVERLAP = 32


#: numba's parallel kernels must not be launched from two threads at once under its
#: "workqueue" threading layer, the fallback when neither TBB nor OpenMP is there (macOS
#: without libomp, a slim container): it aborts the whole process. The station runs
#: analyses in worker threads (the TUI grades a run while it computes a DAVAR), so the
#: compiled launches take turns; each already spreads its work over every core.
_COMPILED_LAUNCH = threading.Lock()
#: Second-difference terms from which ``backend="auto"`` starts numba in a process that has
#: not used it yet: where the compiled kernels save their own start-up. Measured on an idle
#: 2-core machine: numba's first call 1.1 s (1.3 s against numpy's 0.2 s, a tiny record);
#: overlapping sums of 1e7 points at 92 taus (9.2e8 terms) 2.6 s in numpy, 0.46 s compiled,
#: so 2.3 ns saved per term: break-even near 4.8e8 terms for a process that has not loaded
#: numba, but 1.5e8 is taken so that a Python session's calls of 2e6 samples (1.8e8 terms)
#: run compiled: 6-9x allantools' ``oadev`` instead of 2.4x. (GNU OpenMP, numba's default
#: threading layer on Linux, killed process pools forked after such a call; the kernels
#: now pick a fork-safe layer, :mod:`analysis.allan.kernels_numba`.)
COMPILED_MIN_TERMS = 150_000_000
#: The same for the DAVAR's window sums, which numba runs about 5x faster than numpy (3.0
#: ns saved per term; N = 1e6, window 1e5, step 1e4, 85 taus: 0.32 s numpy, 0.066 s
#: compiled, 0.65 s for the first compiled call of a fresh process, measured idle). One
#: call breaks even near 1.9e8 terms; a DAVAR is computed for each axis of a unit, which
#: pays numba's start-up once, so a three-axis unit breaks even at a third of that.
COMPILED_MIN_WINDOW_TERMS = 60_000_000


@lru_cache(maxsize=1)
def _compiled() -> ModuleType | None:
    """The numba kernels (:mod:`analysis.allan.kernels_numba`), or None when numba is not
    installed."""
    try:
        import analysis.allan.kernels_numba as kernels_numba
    except ImportError:
        return None
    return kernels_numba


def compiled_kernels(backend: Backend) -> ModuleType | None:
    """The compiled kernels for a pass whose cost is the record's alone (``"auto"``: where
    numba is installed; ``"numpy"``: None)."""
    return _pick(backend, COMPILED_MIN_TERMS)


def have_compiled() -> bool:
    """True when the compiled (numba) kernels can be used."""
    return _compiled() is not None


def _pick(backend: Backend, work: int, min_terms: int = COMPILED_MIN_TERMS
          ) -> ModuleType | None:
    """The compiled kernels for ``backend`` and ``work`` terms (``auto``: from ``min_terms``
    on), or None for numpy."""
    if backend == "numpy":
        return None
    if backend not in ("auto", "numba"):
        raise ValueError(f"backend must be 'auto', 'numpy' or 'numba', got {backend!r}")
    if backend == "auto" and work < min_terms:
        return None
    kernels = _compiled()
    if kernels is None and backend == "numba":
        raise ImportError("backend='numba' needs numba, which did not import: "
                          "pip install 'numba>=0.59'")
    return kernels


def _overlapping_work(n_points: int, m_arr: NDArray[np.int64], n_axes: int) -> int:
    """Second-difference terms of the overlapping sums of every m and axis."""
    return int(n_axes * (len(m_arr) * n_points - 2 * int(m_arr.sum())))


def overlapping_backend(n_points: int, m_values: NDArray[np.int64], n_axes: int,
                        backend: Backend = "auto") -> ModuleType | None:
    """The compiled kernels :func:`overlapping_sums` runs for this work (None: numpy), so
    that the steps after the sums (noise identification) take the same path: numba only
    where the sums started it anyway."""
    m_arr = np.asarray(m_values, dtype=np.int64)
    return _pick(backend, _overlapping_work(n_points, m_arr, n_axes))


def lag1_moments(angle: NDArray[np.float64], m_values: NDArray[np.int64], d_max: int,
                 compiled: ModuleType) -> NDArray[np.float64]:
    """The compiled lag-1 sums of one axis' angle decimated by each m
    (:func:`analysis.allan.kernels_numba.lag1_moments`), shape (n_m, d_max, 5)."""
    m_arr = np.ascontiguousarray(m_values, dtype=np.int64)
    out = np.empty((len(m_arr), d_max, compiled.LAG1_FIELDS))
    # the m values dealt to every core in turn (a fork-safe threading layer,
    # :mod:`analysis.allan.kernels_numba`, so a process pool forked later is safe)
    n_parts = max(1, min(int(compiled.numba.get_num_threads()), len(m_arr)))
    with _COMPILED_LAUNCH:
        compiled.lag1_moments(np.ascontiguousarray(angle, dtype=np.float64), m_arr, d_max,
                              n_parts, out)
    return out


def running_angle(samples: NDArray[np.float64], mean: NDArray[np.float64], divisor: float,
                  out: NDArray[np.float64], compiled: ModuleType) -> None:
    """The cumulative angle of in-memory ``samples`` (N, k) into ``out`` (N + 1, k) in one
    compiled pass (:func:`analysis.allan.kernels_numba.running_angle`: the numbers of
    :func:`analysis.allan.estimators.cumulative_angle`'s numpy path, bit for bit)."""
    with _COMPILED_LAUNCH:
        compiled.running_angle(np.ascontiguousarray(samples, dtype=np.float64),
                               np.ascontiguousarray(mean, dtype=np.float64), float(divisor), out)


def _check_m(
    m_values: NDArray[np.int64], n_points: int, window: int | None = None
) -> NDArray[np.int64]:
    m = np.ascontiguousarray(m_values, dtype=np.int64)
    limit = (n_points - 1) // 2 if window is None else window // 2
    if m.size and (m.min() < 1 or m.max() > limit):
        raise ValueError(f"averaging factors must be in 1..{limit}, got {m.min()}..{m.max()}")
    return m


# ------------------------------------------------------------------- overlapping Allan sums


def overlapping_sums_reference(
    theta: NDArray[np.float64], m_values: NDArray[np.int64]
) -> NDArray[np.float64]:
    """Overlapping Allan sums written as plainly as possible (the test oracle).

    Parameters
    ----------
    theta : ndarray, shape (N + 1, k)
        Cumulative angle (e.g. deg) per axis.
    m_values : ndarray of int, shape (n_m,)
        Averaging factors (samples), ``1 <= m <= N / 2``.

    Returns
    -------
    ndarray, shape (n_m, k)
        ``sum_n (theta[n+2m] - 2 theta[n+m] + theta[n])^2`` over ``n = 0 .. N - 2m``, in
        (angle unit)^2 (Zhang 2015, eq. 5 before normalisation).
    """
    m_arr = _check_m(m_values, theta.shape[0])
    out = np.empty((len(m_arr), theta.shape[1]))
    for i, m in enumerate(m_arr):
        d = theta[2 * m :] - 2.0 * theta[m : theta.shape[0] - m] + theta[: theta.shape[0] - 2 * m]
        out[i] = (d * d).sum(axis=0)
    return out


def _overlapping_sums_numpy(
    theta_t: NDArray[np.float64], m_arr: NDArray[np.int64]
) -> NDArray[np.float64]:
    """Cache-blocked numpy kernel on an axis-major (k, N + 1) angle array."""
    n_axes, n_points = theta_t.shape
    out = np.zeros((len(m_arr), n_axes))
    buf = np.empty(_NUMPY_BLOCK)
    for c in range(n_axes):
        th = theta_t[c]
        for i, m in enumerate(m_arr):
            length = n_points - 2 * m
            total = 0.0
            for lo in range(0, length, _NUMPY_BLOCK):
                hi = min(lo + _NUMPY_BLOCK, length)
                d = buf[: hi - lo]
                np.subtract(th[lo + 2 * m : hi + 2 * m], th[lo + m : hi + m], out=d)
                d -= th[lo + m : hi + m]
                d += th[lo:hi]
                total += float(np.einsum("i,i->", d, d))  # np.dot: threaded BLAS, slow under load
            out[i, c] = total
    return out


def _overlapping_sums_long(theta: NDArray[np.float64], m_arr: NDArray[np.int64],
                           compiled: ModuleType | None) -> NDArray[np.float64]:
    """Overlapping sums of a long angle record (a memmap), one axis column at a time, in
    blocks of terms; the mapped pages are handed back as it goes (:mod:`analysis.allan.blocks`)."""
    n_points, n_axes = theta.shape
    out = np.zeros((len(m_arr), n_axes))
    buf = np.empty(_NUMPY_BLOCK)
    for c in range(n_axes):
        th = np.asarray(theta[:, c])
        if compiled is not None:
            for i, m in enumerate(m_arr):
                for lo, hi in blocks.spans(0, n_points - 2 * int(m), _LONG_BLOCK):
                    out[i, c] += compiled.span_sum(th, int(m), lo, hi)
                    blocks.release(theta)
            continue
        for i, m in enumerate(m_arr):
            total = 0.0
            for j, (lo, hi) in enumerate(blocks.spans(0, n_points - 2 * int(m), _NUMPY_BLOCK)):
                d = buf[: hi - lo]
                np.subtract(th[lo + 2 * m : hi + 2 * m], th[lo + m : hi + m], out=d)
                d -= th[lo + m : hi + m]
                d += th[lo:hi]
                total += float(np.einsum("i,i->", d, d))
                if j % _RELEASE_EVERY == _RELEASE_EVERY - 1:
                    blocks.release(theta)
            out[i, c] = total
            blocks.release(theta)
    return out


def overlapping_sums(
    theta: NDArray[np.float64], m_values: NDArray[np.int64], *, backend: Backend = "auto"
) -> NDArray[np.float64]:
    """Overlapping Allan sums of squared second differences, per m and axis.

    Same result as :func:`overlapping_sums_reference` (to rounding), one streaming pass
    over ``theta`` per m: the compiled kernel when numba is installed, otherwise numpy on
    blocks that stay in cache. A long memory-mapped ``theta`` (a 24 h run's) is read in
    blocks of terms, one m at a time, and its pages handed back (:mod:`analysis.allan.blocks`).

    Parameters
    ----------
    theta : ndarray, shape (N + 1, k)
        Cumulative angle (e.g. deg) per axis, leading zero included.
    m_values : ndarray of int, shape (n_m,)
        Averaging factors (samples), ``1 <= m <= N / 2``.
    backend : {"auto", "numpy", "numba"}
        Kernel to use; ``"auto"``: numba for large work (module docstring).

    Returns
    -------
    ndarray, shape (n_m, k)
        Sums in (angle unit)^2 over the ``N + 1 - 2m`` second differences.

    Raises
    ------
    ValueError
        If an m is outside ``1 .. N/2`` or the backend is unknown.
    ImportError
        If ``backend="numba"`` and numba is not installed.
    """
    m_arr = _check_m(m_values, theta.shape[0])
    if blocks.is_long(theta.shape[0]) and blocks.is_mapped(theta) and m_arr.size:
        work = _overlapping_work(theta.shape[0], m_arr, theta.shape[1])
        return _overlapping_sums_long(theta, m_arr, _pick(backend, work))
    theta_t = np.ascontiguousarray(np.asarray(theta, dtype=np.float64).T)
    kernels = _pick(backend, _overlapping_work(theta_t.shape[1], m_arr, theta_t.shape[0]))
    if kernels is None or m_arr.size == 0:
        return _overlapping_sums_numpy(theta_t, m_arr)
    out = np.empty((len(m_arr), theta_t.shape[0]))
    with _COMPILED_LAUNCH:
        kernels.oadev_sums(theta_t, m_arr, out)
    return out


def _stretch_sums_numpy(theta_t: NDArray[np.float64], m_arr: NDArray[np.int64],
                        starts: NDArray[np.int64], stops: NDArray[np.int64]) -> NDArray[np.float64]:
    """Cache-blocked numpy kernel of :func:`overlapping_stretch_sums` (axis-major angle)."""
    n_axes, n_points = theta_t.shape
    # the end (exclusive) of the stretch each term index starts in
    stretch_end = np.repeat(stops, stops - starts)
    out = np.zeros((len(m_arr), n_axes))
    buf = np.empty(_NUMPY_BLOCK)
    for i, m in enumerate(m_arr):
        length = n_points - 2 * m
        for lo in range(0, max(length, 0), _NUMPY_BLOCK):
            hi = min(lo + _NUMPY_BLOCK, length)
            keep = (np.arange(lo, hi) + 2 * m <= stretch_end[lo:hi]).astype(float)
            for c in range(n_axes):
                th = theta_t[c]
                d = buf[: hi - lo]
                np.subtract(th[lo + 2 * m : hi + 2 * m], th[lo + m : hi + m], out=d)
                d -= th[lo + m : hi + m]
                d += th[lo:hi]
                out[i, c] += float(np.einsum("i,i,i->", d, d, keep))
    return out


def overlapping_stretch_sums(
    theta: NDArray[np.float64], m_values: NDArray[np.int64], starts: NDArray[np.int64],
    stops: NDArray[np.int64], *, backend: Backend = "auto",
) -> NDArray[np.float64]:
    """Overlapping Allan sums of a record cut into gap-free stretches, per m and axis.

    Only the second differences ``theta[k+2m] - 2 theta[k+m] + theta[k]`` whose ``2m``
    samples all lie in one stretch are summed (:mod:`analysis.allan.gaps`).

    Parameters
    ----------
    theta : ndarray, shape (n + 1, k)
        Cumulative angle of the concatenated present samples (leading zero).
    m_values : ndarray of int, shape (n_m,)
        Averaging factors (samples), ``1 <= m <= n / 2``.
    starts, stops : ndarray of int, shape (n_stretches,)
        Each stretch's first and one-past-last sample index into the concatenated
        samples, in order, covering ``0 .. n`` without overlap.
    backend : {"auto", "numpy", "numba"}
        Kernel to use; ``"auto"``: numba for large work (module docstring).

    Returns
    -------
    ndarray, shape (n_m, k)
        Sums in (angle unit)^2. With one stretch, :func:`overlapping_sums`.
    """
    m_arr = _check_m(m_values, theta.shape[0])
    starts = np.ascontiguousarray(starts, dtype=np.int64)
    stops = np.ascontiguousarray(stops, dtype=np.int64)
    if (
        starts.size == 0
        or starts[0] != 0
        or stops[-1] != theta.shape[0] - 1
        or np.any(starts[1:] != stops[:-1])
    ):
        raise ValueError(
            "stretches must cover the samples in order, each starting where the last stopped"
        )
    if blocks.is_mapped(theta) and blocks.is_long(theta.shape[0]):
        return _stretch_sums_long(theta, m_arr, starts, stops, backend)
    theta_t = np.ascontiguousarray(np.asarray(theta, dtype=np.float64).T)
    kernels = _pick(backend, _overlapping_work(theta_t.shape[1], m_arr, theta_t.shape[0]))
    if kernels is None or m_arr.size == 0:
        return _stretch_sums_numpy(theta_t, m_arr, starts, stops)
    out = np.empty((len(m_arr), theta_t.shape[0]))
    with _COMPILED_LAUNCH:
        kernels.oadev_stretch_sums(theta_t, m_arr, starts, stops, out)
    return out


def _stretch_sums_long(theta: NDArray[np.float64], m_arr: NDArray[np.int64],
                       starts: NDArray[np.int64], stops: NDArray[np.int64], backend: Backend
                       ) -> NDArray[np.float64]:
    """:func:`overlapping_stretch_sums` of a memory-mapped angle: a stretch longer than a
    block through :func:`overlapping_sums` (which walks it a block at a time), shorter ones
    in groups spanning at most a block; the angle's pages are handed back after each."""
    out = np.zeros((len(m_arr), theta.shape[1]))
    i = 0
    while i < len(starts):
        a = int(starts[i])
        j = i + 1
        while j < len(starts) and int(stops[j]) - a <= blocks.BLOCK_SAMPLES:
            j += 1
        b = int(stops[j - 1])
        fits = 2 * m_arr <= int(np.max(stops[i:j] - starts[i:j]))  # any difference at all
        if fits.any():
            part = theta[a : b + 1]
            if j == i + 1:
                out[fits] += overlapping_sums(part, m_arr[fits], backend=backend)
            else:
                out[fits] += overlapping_stretch_sums(part, m_arr[fits], starts[i:j] - a,
                                                      stops[i:j] - a, backend=backend)
        blocks.release(theta)
        i = j
    return out


# ------------------------------------------------------------------------ DAVAR window sums


def second_difference_squares(theta: NDArray[np.float64], m: int) -> NDArray[np.float64]:
    """``Delta_m(k)^2`` for every ``k = 0 .. len(theta) - 1 - 2m`` of a 1-D angle (Zhang 2015, eq.
    15)."""
    n = theta.shape[0] - 2 * m
    d = theta[2 * m :] - theta[m : m + n]
    d -= theta[m : m + n]
    d += theta[:n]
    d *= d
    return d


def _terms_into(buf: NDArray[np.float64], theta: NDArray[np.float64], m: int, lo: int, hi: int
                ) -> NDArray[np.float64]:
    """``Delta_m(k)^2`` for ``k = lo .. hi - 1`` written into ``buf[: hi - lo]`` (returned)."""
    d = buf[: hi - lo]
    np.subtract(theta[lo + 2 * m : hi + 2 * m], theta[lo + m : hi + m], out=d)
    d -= theta[lo + m : hi + m]
    d += theta[lo:hi]
    d *= d
    return d


def _segment_window_sums_numpy(theta: NDArray[np.float64], m: int, starts: NDArray[np.int64],
                               n_terms: int) -> NDArray[np.float64]:
    """Window sums of one m from the segments between window edges (steps not much shorter
    than the window): each term is summed once, a chunk of terms at a time, and each window
    adds up its few segments; no running sum is subtracted."""
    cuts = np.union1d(starts, starts + n_terms)
    segments = np.zeros(len(cuts))  # the last entry stays 0: the padding of a window's row
    buf = np.empty(_NUMPY_BLOCK)
    for a in range(int(cuts[0]), int(cuts[-1]), _NUMPY_BLOCK):
        b = min(a + _NUMPY_BLOCK, int(cuts[-1]))
        i0 = int(np.searchsorted(cuts, a, side="right"))  # first cut after a
        i1 = int(np.searchsorted(cuts, b, side="left"))  # first cut at or after b
        at = np.concatenate(([0], cuts[i0:i1] - a))
        segments[i0 - 1 : i1] += np.add.reduceat(_terms_into(buf, theta, m, a, b), at)
    first = np.searchsorted(cuts, starts)
    count = np.searchsorted(cuts, starts + n_terms) - first
    take = first[:, None] + np.arange(int(count.max()))
    take[take >= first[:, None] + count[:, None]] = len(cuts) - 1
    out: NDArray[np.float64] = segments[take].sum(axis=1)
    return out


def _block_window_sums_numpy(theta: NDArray[np.float64], m: int, starts: NDArray[np.int64],
                             n_terms: int) -> NDArray[np.float64]:
    """Window sums of one m from block prefix and suffix sums (any step): the terms are cut
    into blocks of one window's ``L`` terms; a window starting at offset ``r`` of block
    ``q`` is block q's suffix from ``r`` plus block ``q + 1``'s prefix up to ``r``. Whole
    blocks are handled a chunk of about :data:`_NUMPY_BLOCK` terms at a time."""
    length = n_terms
    lo = int(starts[0]) // length * length
    end = int(starts[-1]) + length  # terms needed: lo .. end - 1
    per_chunk = length * max(1, _NUMPY_BLOCK // length)
    out = np.zeros(len(starts))
    ends = starts + length
    buf = np.zeros(per_chunk)
    for a in range(lo, end, per_chunk):
        b = min(a + per_chunk, end)
        n_blocks = -(-(b - a) // length)
        terms = buf[: n_blocks * length]
        _terms_into(terms, theta, m, a, b)
        terms[b - a :] = 0.0
        blocks = terms.reshape(n_blocks, length)
        suffix = np.cumsum(blocks[:, ::-1], axis=1)[:, ::-1].ravel()
        prefix = np.zeros_like(blocks)
        np.cumsum(blocks[:, :-1], axis=1, out=prefix[:, 1:])
        top = a + n_blocks * length
        j0, j1 = np.searchsorted(starts, [a, top])
        out[j0:j1] += suffix[starts[j0:j1] - a]
        k0, k1 = np.searchsorted(ends, [a, top])
        out[k0:k1] += prefix.ravel()[ends[k0:k1] - a]
    return out


def _window_sums_numpy(
    theta: NDArray[np.float64], m_arr: NDArray[np.int64], starts: NDArray[np.int64], window: int
) -> NDArray[np.float64]:
    """Numpy window sums, one m at a time over chunks of terms: memory of one chunk (or one
    window's terms), never a record-long array per m."""
    out = np.empty((len(starts), len(m_arr)))
    shortest_step = int(np.diff(starts).min()) if len(starts) > 1 else window
    segments = window <= _SEGMENTS_MAX_OVERLAP * shortest_step
    for i, m in enumerate(m_arr):
        n_terms = window + 1 - 2 * int(m)
        kernel = _segment_window_sums_numpy if segments else _block_window_sums_numpy
        out[:, i] = kernel(theta, int(m), starts, n_terms)
    return out


def window_sums(
    theta: NDArray[np.float64],
    m_values: NDArray[np.int64],
    starts: NDArray[np.int64],
    window: int,
    *,
    backend: Backend = "auto",
) -> NDArray[np.float64]:
    """Sliding-window sums of ``Delta_m(k)^2`` for the DAVAR (Zhang 2015, eq. 6 and 15).

    The window of ``window`` samples starting at sample ``s`` spans the angle points
    ``theta[s .. s + window]`` and holds the ``L = window + 1 - 2m`` terms
    ``k = s .. s + L - 1``. Every window sum is O(1) once the block prefix and suffix
    sums of the terms are known (see the module docstring for why not one running sum).

    Parameters
    ----------
    theta : ndarray, shape (n + 1,)
        Cumulative angle of one axis (e.g. deg); any additive constant cancels.
    m_values : ndarray of int, shape (n_m,)
        Averaging factors (samples), ``1 <= m <= window / 2``.
    starts : ndarray of int, shape (n_windows,)
        Increasing window starts (samples), with ``starts[-1] + window <= n``.
    window : int
        Window length Nw in samples.
    backend : {"auto", "numpy", "numba"}
        Kernel to use; ``"auto"``: numba for large work (module docstring).

    Returns
    -------
    ndarray, shape (n_windows, n_m)
        Window sums in (angle unit)^2.

    Raises
    ------
    ValueError
        If an m or a window start is out of range.
    """
    theta = np.ascontiguousarray(theta, dtype=np.float64)
    m_arr = _check_m(m_values, theta.shape[0], window)
    starts = np.ascontiguousarray(starts, dtype=np.int64)
    if starts.size == 0:
        return np.zeros((0, len(m_arr)))
    if starts[0] < 0 or starts[-1] + window > theta.shape[0] - 1 or np.any(np.diff(starts) <= 0):
        raise ValueError("window starts must increase and keep every window inside theta")
    kernels = _pick(backend, len(m_arr) * int(starts[-1] + window - starts[0]),
                    COMPILED_MIN_WINDOW_TERMS)
    # Few windows per window length: sum segments between window edges once each;
    # many (small steps): block prefix and suffix sums, one pass each.
    shortest_step = int(np.diff(starts).min()) if len(starts) > 1 else window
    segments = window <= _SEGMENTS_MAX_OVERLAP * shortest_step
    if segments and blocks.is_mapped(theta) and blocks.is_long(theta.shape[0]):
        return _mapped_segment_window_sums(theta, m_arr, starts, window, kernels)
    if kernels is None or m_arr.size == 0:
        return _window_sums_numpy(theta, m_arr, starts, window)
    out = np.empty((len(starts), len(m_arr)))
    with _COMPILED_LAUNCH:
        if segments:
            kernels.window_sums_segments(theta, m_arr, starts, window, out)
        else:
            by_m = np.empty((len(m_arr), len(starts)))
            kernels.window_sums(theta, m_arr, starts, window, by_m)
            out[:] = by_m.T
    return out


def _mapped_segment_window_sums(theta: NDArray[np.float64], m_arr: NDArray[np.int64],
                                starts: NDArray[np.int64], window: int,
                                kernels: ModuleType | None) -> NDArray[np.float64]:
    """Window sums of a long memory-mapped angle from the segments between window edges,
    one m and one block of terms at a time, the angle's pages handed back after each
    block: the resident angle stays about three blocks whatever the window's length (the
    compiled kernels would map in the whole stretch of windows)."""
    out = np.empty((len(starts), len(m_arr)))
    buf = np.empty(blocks.BLOCK_SAMPLES)
    for i, m in enumerate(int(v) for v in m_arr):
        n_terms = window + 1 - 2 * m
        cuts = np.union1d(starts, starts + n_terms)
        segment = np.zeros(len(cuts) - 1)
        for j in range(len(cuts) - 1):
            for lo, hi in blocks.spans(int(cuts[j]), int(cuts[j + 1])):
                if kernels is not None:
                    with _COMPILED_LAUNCH:
                        segment[j] += kernels.span_sum(theta, m, lo, hi)
                else:
                    segment[j] += float(_terms_into(buf, theta, m, lo, hi).sum())
                blocks.release(theta)
        first = np.searchsorted(cuts, starts)
        last = np.searchsorted(cuts, starts + n_terms)
        out[:, i] = [segment[a:b].sum() for a, b in zip(first, last, strict=True)]
    return out

