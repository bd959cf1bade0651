"""The double sum behind Theo1, computed directly or by correlations (fast, exact in exact
arithmetic).

Theo1 at an even averaging factor m over ``P`` angle (phase) points ``x`` is (NIST SP 1065,
eq. 30, 0-based, ``c = m/2``, ``u = i + c``)

    T(m) = sum_{u=c}^{P-1-c} sum_{delta=0}^{c-1} w_delta (x_{u-c} + x_{u+c} - x_{u-delta} -
    x_{u+delta})^2

with ``w_delta = 1 / (c - delta)``; Theo1 is ``T / (0.75 (P - m) (m tau0)^2)``. Summed as
written it costs ``(P - m) m / 2`` terms per tau, about ``N^2 / 8`` near ``m = N/2``: hours
at a million samples. Expanding the square turns every piece into a correlation sum of
``x``: the full autocorrelation (one FFT per record), the autocorrelations of the first
and last m points (an FFT of length 2m per tau), prefix sums of ``x^2``, and two corner
sums ``sum_{p+q<m-1} K(q-p) x_p x_q`` over the first (and last) m points, which a
divide-and-conquer into square blocks (each an FFT correlation, batched per level) gives
in ``O(m log^2 m)``. The expansion trades exactness for rounding: terms of the size of
``sum x^2`` cancel down to ``T``, so the relative rounding error grows with the ratio
of the angle's spread to the Theo1 differences (large at short tau on a record that
wanders far: 3e-6 at m = 200 on 2e5 points of pure rate random walk, 1e-12 on white
rate noise, measured against the direct sum). :func:`theo1_sums` therefore sums directly
while that costs at most :data:`DIRECT_TERMS` terms per tau, uses the correlations beyond
(after removing the best straight line from ``x``, which Theo1 does not see), and sums
directly after all where their rounding bound is too large and the direct sum affordable.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

#: Taus whose direct double sum has at most this many terms are summed directly.
DIRECT_TERMS = 20_000_000
#: Relative rounding error the correlations may carry before a tau is summed directly.
TARGET_RELATIVE_ERROR = 1e-6
#: ...but only while the direct sum has at most this many terms (a few seconds).
DIRECT_TERMS_MAX = 100_000_000
#: Rows of the direct sum evaluated at once (memory: this many times P doubles).
_DIRECT_CHUNK_VALUES = 4_000_000
#: Corner triangles of at most this size are summed as small dense blocks.
_LEAF = 32


def _weights(c: int) -> NDArray[np.float64]:
    return 1.0 / (c - np.arange(c, dtype=float))


def theo1_sum_direct(x: NDArray[np.float64], m: int) -> float:
    """``T(m)`` summed term by term (vectorized over blocks of delta): the reference."""
    p = len(x)
    c, n = m // 2, p - m
    ends = x[:n] + x[m : m + n]
    windows = np.lib.stride_tricks.sliding_window_view(x, n)
    w = _weights(c)
    total = 0.0
    chunk = max(1, _DIRECT_CHUNK_VALUES // max(n, 1))
    for lo in range(0, c, chunk):
        delta = np.arange(lo, min(c, lo + chunk))
        z = ends[None, :] - windows[c - delta] - windows[c + delta]
        total += float(np.einsum("ij,ij,i->", z, z, w[delta]))
    return total


def _autocorrelation(x: NDArray[np.float64], max_lag: int) -> NDArray[np.float64]:
    """``sum_j x_j x_{j+L}`` for ``L = 0 .. max_lag`` (zero past the end), by FFT."""
    from scipy import fft as sp_fft
    size = sp_fft.next_fast_len(len(x) + max_lag + 1, real=True)
    spec = sp_fft.rfft(x, size)
    out = np.asarray(sp_fft.irfft(spec * np.conj(spec), size)[: max_lag + 1], dtype=np.float64)
    if len(out) < max_lag + 1:
        out = np.concatenate([out, np.zeros(max_lag + 1 - len(out))])
    out[len(x):] = 0.0
    return out


def _kernel_table(c: int) -> NDArray[np.float64]:
    """``K(d) = 1 / (c - |d|/2)`` for even ``|d| < 2c``, else 0, tabulated at ``d + 2c`` for
    ``d = -2c .. 2c`` (the corner-sum weights; a look-up is cheaper than the formula)."""
    d = np.arange(-2 * c, 2 * c + 1)
    a = np.abs(d)
    ok = (a % 2 == 0) & (a < 2 * c)
    return np.where(ok, 1.0 / np.where(ok, c - a / 2.0, 1.0), 0.0)


def _kernel(table: NDArray[np.float64], c: int, d: NDArray[np.int64]) -> NDArray[np.float64]:
    """``K(d)`` from :func:`_kernel_table` (zero outside ``|d| <= 2c``)."""
    idx = d + 2 * c
    inside = (idx >= 0) & (idx < len(table))
    return np.where(inside, table[np.clip(idx, 0, len(table) - 1)], 0.0)


def _gather(x: NDArray[np.float64], start: NDArray[np.int64], length: int) -> NDArray[np.float64]:
    """Rows ``x[start_b : start_b + length]``, zero where a row runs past the end."""
    idx = start[:, None] + np.arange(length)[None, :]
    inside = idx < len(x)
    return np.where(inside, x[np.minimum(idx, len(x) - 1)], 0.0)


def _triangle_sum(x: NDArray[np.float64], c: int, roots: NDArray[np.int64]) -> float:
    """Sum over roots (a, b, n) of ``sum_{i, j >= 0, i + j < n} x_{a+i} x_{b+j} K(b + j - a - i)``.

    A triangle ``{i + j < n}`` at offsets (a, b) splits into the square ``i, j < h``
    (``h = ceil(n/2)``), whose sum is an FFT correlation, and two triangles of size
    ``n - h`` at (a + h, b) and (a, b + h). All squares of one level are done in one
    batched FFT; triangles of at most :data:`_LEAF` are summed as dense blocks.
    """
    from scipy import fft as sp_fft
    tasks = np.asarray(roots, dtype=np.int64).reshape(-1, 3)
    table = _kernel_table(c)
    total = 0.0
    while len(tasks):
        leaf = tasks[:, 2] <= _LEAF
        total += _leaf_sums(x, table, c, tasks[leaf])
        tasks = tasks[~leaf]
        if not len(tasks):
            break
        a, b, n = tasks[:, 0], tasks[:, 1], tasks[:, 2]
        h = (n + 1) // 2
        hmax = int(h.max())
        xa = _gather(x, a, hmax)
        xb = _gather(x, b, hmax)
        valid = np.arange(hmax)[None, :] < h[:, None]
        xa, xb = xa * valid, xb * valid
        # v_i = sum_j K(b - a + j - i) xb_j: the full convolution of the reversed kernel
        # segment K(D + t), t = -(hmax-1) .. hmax-1, with xb, read at hmax-1+i
        t = np.arange(-(hmax - 1), hmax)
        seg = _kernel(table, c, (b - a)[:, None] + t[None, ::-1])
        size_fft = sp_fft.next_fast_len(3 * hmax - 2, real=True)
        conv = sp_fft.irfft(sp_fft.rfft(seg, size_fft, axis=1) * sp_fft.rfft(xb, size_fft, axis=1),
                            size_fft, axis=1)
        v = conv[:, hmax - 1 : 2 * hmax - 1]
        total += float(np.sum(xa * v))
        rest = n - h
        keep = rest > 0
        tasks = np.concatenate([np.stack([a + h, b, rest], axis=1)[keep],
                                np.stack([a, b + h, rest], axis=1)[keep]])
    return total


def _leaf_sums(
    x: NDArray[np.float64], table: NDArray[np.float64], c: int, tasks: NDArray[np.int64]
) -> float:
    """Small triangles summed densely, one diagonal ``t = j - i`` of their (Toeplitz) kernel at a
    time."""
    if not len(tasks):
        return 0.0
    total = 0.0
    i = np.arange(_LEAF)
    offsets = np.arange(-(_LEAF - 1), _LEAF)
    for lo in range(0, len(tasks), 8192):
        part = tasks[lo : lo + 8192]
        a, b, n = part[:, 0], part[:, 1], part[:, 2]
        xa, xb = _gather(x, a, _LEAF), _gather(x, b, _LEAF)
        seg = _kernel(table, c, (b - a)[:, None] + offsets[None, :])
        for k, t in enumerate(offsets.tolist()):
            first, stop = max(0, -t), min(_LEAF, _LEAF - t)
            inside = (2 * i[first:stop] + t)[None, :] < n[:, None]  # i + j < n
            prod = xa[:, first:stop] * xb[:, first + t : stop + t]
            total += float(np.einsum("bi,bi,b->", prod, inside, seg[:, k]))
    return total


def _corners(x: NDArray[np.float64], c: int) -> float:
    """``sum_{delta<c} w_delta sum_{j=0}^{c-delta-1} x_j x_{j+2 delta}`` plus the same of the
    reversed ``x`` (the two ends the strip of all pairs overshoots; each uses 2c - 1 points)."""
    if c <= 0:
        return 0.0
    size = 2 * c - 1
    ends = np.concatenate([x[:size], x[::-1][:size]])
    # over p <= q with q - p even: half the symmetric triangle sum plus half its diagonal
    full = _triangle_sum(ends, c, np.array([[0, 0, size], [size, size, size]]))
    diagonal = (float(np.einsum("i,i->", ends[:c], ends[:c]))
                + float(np.einsum("i,i->", ends[size:size + c], ends[size:size + c]))) / c
    return 0.5 * (full + diagonal)


def theo1_sum_fast(
    x: NDArray[np.float64], m: int, full_acf: NDArray[np.float64]
) -> tuple[float, float]:
    """``T(m)`` from correlation sums, and the size of its largest cancelling term.

    ``full_acf`` is :func:`_autocorrelation` of ``x`` to a lag of at least m.
    """
    p = len(x)
    c, n = m // 2, p - m
    w = _weights(c)
    delta = np.arange(c)
    ends = x[:n] + x[m : m + n]
    term_ends = w.sum() * float(np.einsum("i,i->", ends, ends))
    head_acf = _autocorrelation(x[:m], m)
    tail_acf = _autocorrelation(x[n:], m)
    front = full_acf[: m + 1] - tail_acf  # sum_{j=0}^{n-1} x_j x_{j+L}
    back = full_acf[: m + 1] - head_acf  # sum_{j=m-L}^{P-1-L} x_j x_{j+L}
    cross = float(w @ (front[c - delta] + front[c + delta] + back[c + delta] + back[c - delta]))
    squares = np.concatenate([[0.0], np.cumsum(x * x)])
    inner_sq = float(
        w
        @ (
            squares[c - delta + n]
            - squares[c - delta]
            + squares[c + delta + n]
            - squares[c + delta]
        )
    )
    strip = float(w @ full_acf[2 * delta])
    pairs = strip - _corners(x, c)
    # every piece is at most 4 W sum(x^2) in size (Cauchy-Schwarz), the FFT sums' rounding too
    size = 4.0 * float(np.sum(w)) * float(squares[-1])
    return term_ends - 2.0 * cross + inner_sq + 2.0 * pairs, size


def theo1_sums(
    x: NDArray[np.float64], m_values: NDArray[np.int64], *, method: str = "auto"
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``T(m)`` of one axis' angle ``x`` (P points) at each even ``m`` (``2 <= m <= P - 1``).

    ``method="auto"`` sums directly while ``(P - m) m / 2 <= DIRECT_TERMS``, by correlations
    beyond, and directly again where the correlations' rounding bound exceeds
    :data:`TARGET_RELATIVE_ERROR` and the direct sum costs at most :data:`DIRECT_TERMS_MAX`
    terms; ``"direct"`` and ``"fast"`` force one way (for tests).

    Returns
    -------
    sums : ndarray, shape (n_m,)
        ``T(m)`` in (angle unit)^2.
    error_bound : ndarray, shape (n_m,)
        Bound on the relative rounding error of each sum: ``1e-15`` for a direct sum,
        ``100 eps S / T`` for the correlations (``S = 4 sum(w) sum(x^2)`` bounds the size of
        every cancelling term; measured errors were below 60 eps S / T).
    """
    x = np.asarray(x, dtype=float)
    p = len(x)
    m_values = np.asarray(m_values, dtype=np.int64)
    if method not in ("auto", "direct", "fast"):
        raise ValueError(f"method must be 'auto', 'direct' or 'fast', got {method!r}")
    terms = (p - m_values) * (m_values // 2)
    direct = (
        terms <= DIRECT_TERMS if method == "auto" else np.full(len(m_values), method == "direct")
    )
    out = np.empty(len(m_values))
    bound = np.full(len(m_values), 1e-15)
    if (~direct).any():
        t = np.arange(p, dtype=float)
        xf = x - np.polyval(np.polyfit(t, x, 1), t)  # Theo1 does not see a straight line
        acf = _autocorrelation(xf, int(m_values[~direct].max()))
    for i, m in enumerate(m_values):
        if direct[i]:
            out[i] = theo1_sum_direct(x, int(m))
            continue
        out[i], size = theo1_sum_fast(xf, int(m), acf)
        bound[i] = 100 * np.finfo(float).eps * size / max(abs(out[i]), np.finfo(float).tiny)
        if method == "auto" and bound[i] > TARGET_RELATIVE_ERROR and terms[i] <= DIRECT_TERMS_MAX:
            out[i], bound[i] = theo1_sum_direct(x, int(m)), 1e-15
    return out, bound
