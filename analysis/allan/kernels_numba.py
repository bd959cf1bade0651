"""Compiled (numba) kernels behind :mod:`analysis.allan.kernels`; imported only when numba is
installed.

Same results as the numpy kernels there, to rounding. Compiled on first use and cached
on disk by numba (``cache=True``). Callers pass checked, contiguous float64/int64 arrays.
"""

from __future__ import annotations

import os

import numba
import numpy as np
from numpy.typing import NDArray

if "NUMBA_THREADING_LAYER" not in os.environ:
    # A fork-safe threading layer (TBB where installed, else numba's own "workqueue"), set
    # before the first parallel launch: numba's default prefers GNU OpenMP on Linux, whose
    # threads do not survive fork(), and numba then kills a forked child that launches a
    # parallel kernel ("fork() called from a process already using GNU OpenMP"), as a
    # process pool forked after an in-process analysis does (``station reproduce``). The
    # "workqueue" layer is not thread-safe, which the launch lock of
    # :mod:`analysis.allan.kernels` covers. Measured on the 2-core machine, loaded: 1e7
    # points x 92 taus 0.9-1.7 s under either layer, first call 0.8-1.4 s under either;
    # the other cure, pools started by "forkserver" or "spawn", costs 4.7-6.5 s to bring up
    # two workers that import the reproduce study (0.05 s forked), so the pools stay forked.
    numba.config.THREADING_LAYER = "forksafe"  # type: ignore[attr-defined]

#: Terms per partial sum of a long reduction (bounds its rounding error).
_BLOCK = 1 << 12


@numba.njit(parallel=True, cache=True)
def oadev_sums(
    theta_t: NDArray[np.float64], m_values: NDArray[np.int64], out: NDArray[np.float64]
) -> None:
    """``out[i, c] = oadev_one(theta_t[c], m_values[i])``, the (m, axis) pairs spread over cores."""
    n_axes = theta_t.shape[0]
    for job in numba.prange(m_values.shape[0] * n_axes):
        i = job // n_axes
        c = job % n_axes
        out[i, c] = oadev_one(theta_t[c], m_values[i])


@numba.njit(parallel=True, cache=True)
def oadev_stretch_sums(
    theta_t: NDArray[np.float64],
    m_values: NDArray[np.int64],
    starts: NDArray[np.int64],
    stops: NDArray[np.int64],
    out: NDArray[np.float64],
) -> None:
    """``out[i, c]``: sum of ``Delta_m(k)^2`` over the k whose ``2m`` samples lie in one stretch.

    Stretch j holds samples ``starts[j] .. stops[j] - 1`` of the concatenated record, so
    its terms are ``k = starts[j] .. stops[j] - 2m``; each is a span of :func:`_span_sum`.
    """
    n_axes = theta_t.shape[0]
    for job in numba.prange(m_values.shape[0] * n_axes):
        i = job // n_axes
        c = job % n_axes
        m = m_values[i]
        total = 0.0
        for j in range(starts.shape[0]):
            hi = stops[j] + 1 - 2 * m
            if hi > starts[j]:
                total += _span_sum(theta_t[c], m, starts[j], hi)
        out[i, c] = total


@numba.njit(parallel=True, cache=True)
def window_sums(
    theta: NDArray[np.float64],
    m_values: NDArray[np.int64],
    starts: NDArray[np.int64],
    window: int,
    out: NDArray[np.float64],
) -> None:
    """``out[i, j]``: sum of ``Delta_m(k)^2`` over the ``window + 1 - 2m`` terms from ``starts[j]``.

    ``out`` is (n_m, n_windows), so each m writes one contiguous row. The scheme of the
    numpy kernel, fused: the terms are cut into blocks of one window's
    length ``L``; within each block a prefix sum and a suffix sum restart at its edges, so a
    window (which spans at most two blocks) is one block's suffix plus the next block's
    prefix: no subtraction of large running sums (the float64 trap of Zhang 2015, eq. 17),
    and each partial sum holds at most L positive terms. One m per job.
    """
    n_starts = starts.shape[0]
    for i in numba.prange(m_values.shape[0]):
        m = m_values[i]
        n_terms = window + 1 - 2 * m
        lo = (starts[0] // n_terms) * n_terms
        size = starts[n_starts - 1] + n_terms - lo
        d = np.empty(size)
        for idx in range(size):
            k = lo + idx
            x = theta[k + 2 * m] - 2.0 * theta[k + m] + theta[k]
            d[idx] = x * x
        prefix = np.empty(size + 1)  # sum of the block's terms before idx
        suffix = np.empty(size)  # sum of the block's terms from idx on
        acc = 0.0
        for block in range(0, size, n_terms):
            end = min(block + n_terms, size)
            acc = 0.0
            for idx in range(block, end):
                prefix[idx] = acc
                acc += d[idx]
            back = 0.0
            for idx in range(end - 1, block - 1, -1):
                back += d[idx]
                suffix[idx] = back
        prefix[size] = acc if size % n_terms != 0 else 0.0
        row = out[i]  # out is (n_m, n_windows): one contiguous row per m
        for j in range(n_starts):
            r = starts[j] - lo
            row[j] = suffix[r] + prefix[r + n_terms]


@numba.njit(fastmath={"reassoc", "contract"})
def _span_sum(theta: NDArray[np.float64], m: int, lo: int, hi: int) -> float:
    """Sum of ``Delta_m(k)^2`` over ``k = lo .. hi - 1`` (vectorized, in blocks)."""
    total = 0.0
    for start in range(lo, hi, _BLOCK):
        stop = min(start + _BLOCK, hi)
        a, b, c = (
            theta[start + 2 * m : stop + 2 * m],
            theta[start + m : stop + m],
            theta[start:stop],
        )
        part = 0.0
        for n in range(stop - start):
            d = a[n] - 2.0 * b[n] + c[n]
            part += d * d
        total += part
    return total


@numba.njit(cache=True)
def span_sum(th: NDArray[np.float64], m: int, lo: int, hi: int) -> float:
    """Sum of ``Delta_m(k)^2`` over ``k = lo .. hi - 1``, on one core: one block of a
    memory-mapped record for one m (three streams through ``th``, handed back block by
    block). One core: thousands of parallel launches cost more than they gain on a
    loaded machine."""
    return _span_sum(th, m, lo, hi)


@numba.njit(cache=True)
def oadev_one(th: NDArray[np.float64], m: int) -> float:
    """Sum of ``(th[n+2m] - 2 th[n+m] + th[n])^2`` over ``n = 0 .. len(th) - 1 - 2m``."""
    return _span_sum(th, m, 0, th.shape[0] - 2 * m)


@numba.njit(parallel=True, cache=True)
def window_sums_segments(
    theta: NDArray[np.float64],
    m_values: NDArray[np.int64],
    starts: NDArray[np.int64],
    window: int,
    out: NDArray[np.float64],
) -> None:
    """As :func:`window_sums`, for steps that are not much shorter than the window.

    The window starts and ends cut the terms into segments; each segment is summed once
    (a vectorized loop) and each window adds up its few segments: no subtraction at all,
    and about one pass over the terms per m whatever the step.
    """
    n_starts = starts.shape[0]
    for i in numba.prange(m_values.shape[0]):
        m = m_values[i]
        n_terms = window + 1 - 2 * m
        cuts = np.empty(2 * n_starts, np.int64)  # sorted union of starts and window ends
        a = 0
        b = 0
        n_cuts = 0
        while a < n_starts or b < n_starts:
            if b >= n_starts or (a < n_starts and starts[a] <= starts[b] + n_terms):
                v = starts[a]
                a += 1
            else:
                v = starts[b] + n_terms
                b += 1
            if n_cuts == 0 or cuts[n_cuts - 1] != v:
                cuts[n_cuts] = v
                n_cuts += 1
        segments = np.empty(n_cuts - 1)
        for q in range(n_cuts - 1):
            segments[q] = _span_sum(theta, m, cuts[q], cuts[q + 1])
        q = 0
        for j in range(n_starts):
            while cuts[q] != starts[j]:
                q += 1
            end = starts[j] + n_terms
            total = 0.0
            r = q
            while cuts[r] != end:
                total += segments[r]
                r += 1
            out[j, i] = total


@numba.njit(cache=True)
def running_angle(samples: NDArray[np.float64], mean: NDArray[np.float64], divisor: float,
                  out: NDArray[np.float64]) -> None:
    """``out[i + 1, c] = out[i, c] + (samples[i, c] - mean[c]) / divisor``, ``out[0] = 0``:
    the cumulative angle in one pass, the same operations in the same order as numpy's
    subtract, divide and cumsum (bit for bit; a divisor of 1 divides exactly)."""
    n, k = samples.shape
    for c in range(k):  # an axis at a time: the running sum stays in a register
        running = 0.0
        centre = mean[c]
        out[0, c] = 0.0
        for i in range(n):
            running += (samples[i, c] - centre) / divisor
            out[i + 1, c] = running


#: Moments per (m, difference order) that :func:`lag1_moments` fills.
LAG1_FIELDS = 5
#: Angle samples per block of :func:`lag1_moments`: every m reads a block while it is in
#: cache, so the record is read from memory once for all m (not once per small m).
_LAG1_BLOCK = 1 << 15


@numba.njit(parallel=True, cache=True)
def lag1_moments(angle: NDArray[np.float64], m_values: NDArray[np.int64], d_max: int,
                 n_parts: int, out: NDArray[np.float64]) -> None:
    """Lag-1 sums of the ``d``-th differences of ``angle[::m]``, every m and ``d <= 3``.

    ``out[i, d - 1] = (n, S1, S2, S11, y_last)`` (``d <= d_max``) for the series ``z`` of
    the d-th difference at ``m_values[i]``, taken about its first value ``c = z[0]``
    (``y = z - c``): ``n`` terms, ``S1 = sum y``, ``S2 = sum y^2``, ``S11 = sum y_i
    y_(i+1)``, and the last ``y``. The m values are dealt to ``n_parts`` cores in turn;
    each walks the angle a cache-sized block at a time and every m of its share reads the
    block, so the record comes from memory once per core for all m, with no temporary.
    :func:`analysis.allan.noise_id.lag1_from_moments` turns the sums into the lag-1
    autocorrelation about the mean.
    """
    n_y = angle.shape[0]
    n_m = m_values.shape[0]
    state = np.zeros((n_m, _LAG1_STATE))
    for part in numba.prange(n_parts):
        for b0 in range(0, n_y, _LAG1_BLOCK):
            b1 = min(b0 + _LAG1_BLOCK, n_y)
            for i in range(part, n_m, n_parts):
                _lag1_block(angle, m_values[i], b0, b1, d_max >= 3, state[i])
    for i in range(n_m):
        count = (n_y - 1) // m_values[i] + 1  # decimated points
        for d in range(1, d_max + 1):
            out[i, d - 1, 0] = max(count - d, 0)
            for f in range(4):
                out[i, d - 1, 1 + f] = state[i, 3 + 5 * (d - 1) + 1 + f]


#: Per m: the previous angle, 1st and 2nd difference, then per difference order its
#: shift (first value), S1, S2, S11 and last shifted value.
_LAG1_STATE = 3 + 5 * 3


@numba.njit(cache=True)
def _lag1_block(angle: NDArray[np.float64], m: int, b0: int, b1: int, third: bool,
                st: NDArray[np.float64]) -> None:
    """The decimated points ``k m`` in ``[b0, b1)`` added to one m's sums ``st`` (the
    third difference's too when ``third``)."""
    p0, p1, p2 = st[0], st[1], st[2]
    c1, s1a, s1b, s1c, l1 = st[3], st[4], st[5], st[6], st[7]
    c2, s2a, s2b, s2c, l2 = st[8], st[9], st[10], st[11], st[12]
    c3, s3a, s3b, s3c, l3 = st[13], st[14], st[15], st[16], st[17]
    k = (b0 + m - 1) // m  # first decimated point in the block
    while k * m < b1:
        a = angle[k * m]
        if k >= 4:  # the common case: every difference has its first value and a last one
            d1 = a - p0
            d2 = d1 - p1
            y1 = d1 - c1
            y2 = d2 - c2
            s1a += y1
            s1b += y1 * y1
            s1c += l1 * y1
            s2a += y2
            s2b += y2 * y2
            s2c += l2 * y2
            if third:
                y3 = d2 - p2 - c3
                s3a += y3
                s3b += y3 * y3
                s3c += l3 * y3
                l3 = y3
            l1, l2 = y1, y2
            p0, p1, p2 = a, d1, d2
        else:
            d1 = a - p0
            d2 = d1 - p1
            d3 = d2 - p2
            if k == 1:
                c1 = d1
            elif k == 2:
                c2 = d2
            elif k == 3:
                c3 = d3
            if k >= 1:
                y1 = d1 - c1
                s1a += y1
                s1b += y1 * y1
                if k > 1:
                    s1c += l1 * y1
                l1 = y1
            if k >= 2:
                y2 = d2 - c2
                s2a += y2
                s2b += y2 * y2
                if k > 2:
                    s2c += l2 * y2
                l2 = y2
            if k >= 3:
                y3 = d3 - c3
                s3a += y3
                s3b += y3 * y3
                l3 = y3
            p0, p1, p2 = a, d1, d2
        k += 1
    st[0], st[1], st[2] = p0, p1, p2
    st[3], st[4], st[5], st[6], st[7] = c1, s1a, s1b, s1c, l1
    st[8], st[9], st[10], st[11], st[12] = c2, s2a, s2b, s2c, l2
    st[13], st[14], st[15], st[16], st[17] = c3, s3a, s3b, s3c, l3


@numba.njit(cache=True)
def rn_sums(th: NDArray[np.float64], m: int) -> tuple[float, float]:
    """Overlapping and modified Allan sums of a 1-D angle at m, in one pass on one core.

    Returns ``(sum_k d(k)^2, sum_j ((S[j+m] - S[j]) / m)^2)`` with ``d(k) = th[k+2m] -
    2 th[k+m] + th[k]`` (``k < len(th) - 2m``) and ``S`` the running sum of ``d`` from
    ``S[0] = 0`` (``j <= len(th) - 3m``): the sums of :func:`analysis.allan.noise_id.rn_ratio`,
    ``S`` taken in the same order as ``np.cumsum`` and kept for the last m entries only.
    """
    length = th.shape[0] - 2 * m
    ring = np.empty(m)  # S[j] at j % m, for the m entries behind the newest
    ring[0] = 0.0
    running = 0.0
    d_square = 0.0
    box_square = 0.0
    slot = 1 % m
    for k in range(length):
        d = th[k + 2 * m] - 2.0 * th[k + m] + th[k]
        d_square += d * d
        running += d
        if k + 1 >= m:
            box = (running - ring[slot]) / m
            box_square += box * box
        ring[slot] = running
        slot += 1
        if slot == m:
            slot = 0
    return d_square, box_square
