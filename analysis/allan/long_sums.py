"""Sums of squared differences of a long angle record, a block at a time.

The Allan family's estimators other than the overlapping and cluster Allan variances
(:mod:`analysis.allan.kernels`) sum squares of other differences of the cumulative angle
``theta`` (one axis, 1-D, e.g. a memmap of a 24 h run):

* modified Allan (MVAR, TVAR): the squared box sums of ``m`` consecutive second
  differences (NIST SP 1065, eq. 14), from the running sum of the second differences
  read twice, ``m`` apart;
* Hadamard (HVAR, OHVAR): third differences ``theta[k+3m] - 3 theta[k+2m] + 3 theta[k+m]
  - theta[k]`` (NIST SP 1065, eq. 18-19), every ``stride``-th k;
* total (TOTVAR): second differences of the angle reflected about both ends (NIST SP
  1065, eq. 25);
* cluster (non-overlapping) Allan: second differences of the cluster edges
  ``theta[k m]``, read a block of the record at a time.

Each walks the record in blocks of :data:`analysis.allan.blocks.BLOCK_SAMPLES` and hands a
memory-mapped record's pages back after each (:func:`analysis.allan.blocks.release`); the sums
equal the in-memory ones to rounding (the running sum is numpy's sequential one exactly).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from numpy.typing import NDArray

import analysis.allan.blocks as blocks


def second_differences(x: NDArray[np.float64], m: int, a: int, b: int) -> NDArray[np.float64]:
    """``x[k+2m] - 2 x[k+m] + x[k]`` for ``k = a .. b - 1`` (a new array)."""
    ahead = np.asarray(x[a + 2 * m : b + 2 * m], dtype=float)
    middle = np.asarray(x[a + m : b + m], dtype=float)
    out: NDArray[np.float64] = ahead - 2.0 * middle + np.asarray(x[a:b], dtype=float)
    return out


def running_sums(x: NDArray[np.float64], m: int, length: int, offset: int
                 ) -> Iterator[NDArray[np.float64]]:
    """``[0, cumsum(d2)]`` from index ``offset`` on, in blocks (``d2`` the ``length``
    second differences at ``m``): the one sequential sum ``np.cumsum`` makes, so equal to
    it exactly."""
    carry = 0.0
    for a, b in blocks.spans(0, length):
        d2 = second_differences(x, m, a, b)
        d2[0] += carry
        sums = np.cumsum(d2)
        carry = float(sums[-1])
        # sums[i] is entry a + 1 + i of [0, cumsum(d2)]
        full, start = (np.concatenate(([0.0], sums)), 0) if a == 0 else (sums, a + 1)
        skip = max(0, offset - start)
        if skip < len(full):
            yield full[skip:]
        blocks.release(x)


def box_square_sum(x: NDArray[np.float64], m: int, divisor: float = 1.0) -> float:
    """``sum_j ((S[j+m] - S[j]) / divisor)^2`` over the ``len(x) - 3m + 1`` box sums of
    ``m`` second differences (``S`` their running sum): the modified Allan sum
    (``divisor`` 1) of a 1-D angle ``x`` in (unit)^2."""
    length = len(x) - 2 * m
    n_box = length + 1 - m
    total = 0.0
    ahead = running_sums(x, m, length, m)
    buffer = np.zeros(0)
    done = 0
    for behind in running_sums(x, m, length, 0):
        take = min(len(behind), n_box - done)
        if take <= 0:
            break
        while len(buffer) < take:
            buffer = np.concatenate((buffer, next(ahead)))
        box = (buffer[:take] - behind[:take]) / divisor
        total += float(np.einsum("i,i->", box, box))
        buffer = buffer[take:]
        done += take
    return total


def hadamard_square_sum(x: NDArray[np.float64], m: int, stride: int) -> float:
    """Sum of the squared third differences at ``m`` of a 1-D angle ``x``, every
    ``stride``-th one from the first, in (unit)^2."""
    n = len(x) - 3 * m
    rows = max(1, blocks.BLOCK_SAMPLES // stride) * stride
    total = 0.0
    for a, b in blocks.spans(0, n, rows):
        d3 = (np.asarray(x[a + 3 * m : b + 3 * m : stride], dtype=float)
              - 3.0 * np.asarray(x[a + 2 * m : b + 2 * m : stride], dtype=float)
              + 3.0 * np.asarray(x[a + m : b + m : stride], dtype=float)
              - np.asarray(x[a:b:stride], dtype=float))
        total += float(np.einsum("i,i->", d3, d3))
        blocks.release(x)
    return total


def _reflected(x: NDArray[np.float64], e0: int, e1: int) -> NDArray[np.float64]:
    """Entries ``e0 .. e1 - 1`` of ``x`` extended by its reflections about both ends
    (``2 x[0] - x[P-2 .. 1]``, ``x``, ``2 x[-1] - x[P-2 .. 1]``, P = len(x)), without
    building the extension."""
    p = len(x)
    left, right = p - 2, 2 * p - 2  # where x itself and the right reflection start
    parts = []
    if e0 < left:
        lo, hi = e0, min(e1, left)  # reflection index r = P - 2 - e
        parts.append(2.0 * float(x[0]) - np.asarray(x[p - 1 - hi : p - 1 - lo], float)[::-1])
    if e1 > left and e0 < right:
        parts.append(np.asarray(x[max(e0, left) - left : min(e1, right) - left], dtype=float))
    if e1 > right:
        lo, hi = max(e0, right) - right, e1 - right  # inner[::-1][i] = x[P - 2 - i]
        parts.append(2.0 * float(x[-1]) - np.asarray(x[p - 1 - hi : p - 1 - lo], float)[::-1])
    return np.concatenate(parts) if len(parts) > 1 else parts[0]


def total_square_sum(x: NDArray[np.float64], m: int) -> float:
    """Sum of the squared second differences at ``m`` of the reflected angle around the
    ``P - 2`` interior points of a 1-D angle ``x`` (P points), in (unit)^2."""
    p = len(x)
    first = p - 1  # extended index of interior point 1
    total = 0.0
    for a, b in blocks.spans(first, first + p - 2):
        d2 = _reflected(x, a + m, b + m) - 2.0 * _reflected(x, a, b) + _reflected(x, a - m, b - m)
        total += float(np.einsum("i,i->", d2, d2))
        blocks.release(x)
    return total


def cluster_square_sums(theta: NDArray[np.float64], m_values: NDArray[np.int64]
                        ) -> NDArray[np.float64]:
    """:func:`analysis.allan.cluster_sums` of a memory-mapped angle (shape (N + 1, k)), one
    m at a time: the cluster edges ``theta[k m]`` are read a block of the record at a time
    (a strided read maps in every page it strides over) and the squared second differences
    summed with the last two edges carried over, per column; the same sums to rounding."""
    n = theta.shape[0] - 1
    out = np.zeros((len(m_values), theta.shape[1]))
    for i, m in enumerate(int(v) for v in m_values):
        last = (n // m) * m  # the last cluster edge
        rows = max(1, blocks.BLOCK_SAMPLES // m) * m
        carry = np.zeros((0, theta.shape[1]))
        for a, b in blocks.spans(0, last + 1, rows):
            edges = np.concatenate((carry, np.asarray(theta[a:b:m], dtype=np.float64)))
            d = np.diff(edges, n=2, axis=0)
            out[i] += np.einsum("jk,jk->k", d, d)
            carry = edges[-2:]
            blocks.release(theta)
    return out
