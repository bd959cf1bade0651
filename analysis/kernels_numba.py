"""Compiled (numba) kernels behind :mod:`analysis.kernels`; imported only when numba is installed.

Same results as the numpy kernels there, to rounding. Compiled on first use and cached
on disk by numba (``cache=True``). Callers pass checked, contiguous float64/int64 arrays.
"""

from __future__ import annotations

import numba
import numpy as np

#: Terms per partial sum of a long reduction (bounds its rounding error).
_BLOCK = 1 << 12


@numba.njit(fastmath={"reassoc", "contract"}, cache=True)
def oadev_one(th, m):
    """Sum of ``(th[n+2m] - 2 th[n+m] + th[n])^2`` over ``n = 0 .. len(th) - 1 - 2m``."""
    # Slices make every index provably non-negative, so the loop vectorizes.
    length = th.shape[0] - 2 * m
    far, mid = th[2 * m :], th[m:]
    total = 0.0
    for start in range(0, length, _BLOCK):
        stop = min(start + _BLOCK, length)
        a, b, c = far[start:stop], mid[start:stop], th[start:stop]
        part = 0.0
        for n in range(stop - start):
            d = a[n] - 2.0 * b[n] + c[n]
            part += d * d
        total += part
    return total


@numba.njit(parallel=True, cache=True)
def oadev_sums(theta_t, m_values, out):
    """``out[i, c] = oadev_one(theta_t[c], m_values[i])``, the (m, axis) pairs spread over cores."""
    n_axes = theta_t.shape[0]
    for job in numba.prange(m_values.shape[0] * n_axes):
        i = job // n_axes
        c = job % n_axes
        out[i, c] = oadev_one(theta_t[c], m_values[i])


@numba.njit(inline="always")
def _term(theta, k, m):
    d = theta[k + 2 * m] - 2.0 * theta[k + m] + theta[k]
    return d * d


@numba.njit(inline="always")
def _add(acc, comp, x):
    """Neumaier's compensated addition: returns the new sum and its running correction."""
    t = acc + x
    if abs(acc) >= abs(x):
        comp += (acc - t) + x
    else:
        comp += (x - t) + acc
    return t, comp


@numba.njit(parallel=True, cache=True)
def window_sums(theta, m_values, starts, window, out):
    """``out[j, i]``: sum of ``Delta_m(k)^2`` over the ``window + 1 - 2m`` terms from ``starts[j]``.

    One m per job; the window slides by adding the terms that enter and subtracting the
    ones that leave (Zhang 2015, eq. 17) in a compensated sum, so the result keeps about
    1e-16 of the window sum however many steps it took. A jump of a whole window or more
    restarts the sum.
    """
    n_starts = starts.shape[0]
    for i in numba.prange(m_values.shape[0]):
        m = m_values[i]
        n_terms = window + 1 - 2 * m
        acc = 0.0
        comp = 0.0
        pos = starts[0]
        for j in range(n_starts):
            new = starts[j]
            if j == 0 or new - pos >= n_terms:
                acc = 0.0
                comp = 0.0
                for k in range(new, new + n_terms):
                    acc, comp = _add(acc, comp, _term(theta, k, m))
            else:
                for k in range(pos, new):
                    acc, comp = _add(acc, comp, _term(theta, k + n_terms, m))
                    acc, comp = _add(acc, comp, -_term(theta, k, m))
            pos = new
            out[j, i] = acc + comp


@numba.njit(fastmath={"reassoc", "contract"})
def _span_sum(theta, m, lo, hi):
    """Sum of ``Delta_m(k)^2`` over ``k = lo .. hi - 1`` (vectorized, in blocks)."""
    total = 0.0
    for start in range(lo, hi, _BLOCK):
        stop = min(start + _BLOCK, hi)
        a, b, c = theta[start + 2 * m : stop + 2 * m], theta[start + m : stop + m], theta[start:stop]
        part = 0.0
        for n in range(stop - start):
            d = a[n] - 2.0 * b[n] + c[n]
            part += d * d
        total += part
    return total


@numba.njit(parallel=True, cache=True)
def window_sums_segments(theta, m_values, starts, window, out):
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
