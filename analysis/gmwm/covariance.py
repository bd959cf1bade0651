"""Covariance of the empirical Haar wavelet variances under a noise model (the GMWM weights).

For a Gaussian process the estimates of eq. W2 (:mod:`analysis.gmwm.wavelet`) at levels i and
j, ``nu_i = (1/M_i) sum_t W_{i,t}^2``, have

    Cov(nu_i, nu_j) = (2 / (M_i M_j)) sum_k n_ij(k) s_ij(k)^2                          (V1)

with ``s_ij(k) = Cov(W_{i,t}, W_{j,t+k})`` the cross-covariance of the coefficients and
``n_ij(k)`` the number of pairs ``(t, t+k)`` inside both ranges of boundary-free
coefficients (Isserlis' theorem: ``Cov(X^2, Y^2) = 2 Cov(X, Y)^2`` for jointly Gaussian
zero-mean X, Y). Each coefficient is a second difference of the angle,
``W_{i,t} = -(fs / 2 m_i) sum_p a_p theta[t + p]`` with weights ``a = (1, -2, 1)`` at
``p = 0, m_i, 2 m_i``, so

    s_ij(k) = -(fs^2 / (8 m_i m_j)) sum_{p,q} a_p b_q D((k + q - p) / fs)               (V2)

with ``D`` the model's angle structure function (:mod:`analysis.gmwm.models`); this holds
for the random walks and flicker noise too, whose ``D`` is generalized, because each set
of weights has zero sum and zero first moment.

``s_ij`` is smooth between the nine kinks ``k = p - q`` (and ``n_ij`` between ``k = 0``
and ``k = M_j - M_i``); it vanishes beyond the overlap of the two windows for white,
quantization and random-walk noise and decays beyond it for Gauss-Markov (over a few
correlation times) and flicker noise (as ``k^-2``). The sum V1 is taken segment by
segment: exactly over short segments, and over long ones as the integral (Gauss-Legendre
on pieces whose widths double away from each end, so that the rapid variation next to a
kink is resolved) plus the Euler-Maclaurin end correction ``(f(a) - f(b)) / 2``. Pieces
of a polynomial ``s`` (white, quantization, random walk) are integrated exactly.

This is the asymptotic covariance of the GMWM papers (Guerrier et al., JASA 2013,
section 3: ``Omega = V^-1`` makes the estimator efficient) computed at a fitted model,
in closed form rather than by a parametric bootstrap of the same model.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import NDArray

from analysis.gmwm.models import GmwmModel

#: Segments up to this many lags are summed lag by lag.
DIRECT_LAGS = 48
#: Gauss-Legendre points per piece.
GL_POINTS = 6
#: Width (lags) of the first piece at each end of a long segment.
FIRST_PIECE = 32
#: Lags beyond the windows' overlap: this many correlation times (Gauss-Markov, AR(1)) ...
TAIL_CORRELATION_TIMES = 12.0
#: ... or this many of the larger window (flicker noise, whose coefficients decay as k^-2).
TAIL_WINDOWS_FLICKER = 64

#: Offset (lags) at which the one-sided limits at a segment's ends are taken.
INSIDE = 1e-4

_GL_X, _GL_W = np.polynomial.legendre.leggauss(GL_POINTS)
_A = np.array([1.0, -2.0, 1.0])


def _pieces(a: int, b: int) -> list[float]:
    """Edges of pieces of ``[a, b]`` whose widths double from each end towards the middle."""
    left, right = [float(a)], [float(b)]
    width = float(FIRST_PIECE)
    while left[-1] + width < right[-1] - width:
        left.append(left[-1] + width)
        right.append(right[-1] - width)
        width *= 2.0
    return left + right[::-1]


def _segments(breaks: list[int]) -> list[tuple[int, int]]:
    """The segments ``[a, b)`` between consecutive breaks that hold a lag."""
    return [(a, b) for a, b in zip(breaks[:-1], breaks[1:], strict=True) if b > a]


def _tail(model: GmwmModel, params: NDArray[np.float64], m_max: int, fs: float) -> int:
    """Lags beyond the windows where the model's coefficients are still correlated (rounded up to
    a power of two, so that nearby models share their quadrature rules)."""
    tail = 0
    for kind, (iv, ish) in zip(model.kinds, model.slices(), strict=True):
        if params[iv] <= 0 or not kind.stochastic:
            continue
        if ish is not None:
            tail = max(tail, int(math.ceil(TAIL_CORRELATION_TIMES * math.exp(params[ish]) * fs)))
        elif kind.code == "bi":
            tail = max(tail, TAIL_WINDOWS_FLICKER * 2 * m_max)
    return 0 if tail == 0 else 1 << int(math.ceil(math.log2(tail)))


def clear_rules() -> None:
    """Drop the quadrature rules kept for the record analysed last (up to 8, each four
    arrays of the record's pairs of levels: 3-7 MB at 7.2e6 samples): the next record's
    fit starts without them."""
    _rules.cache_clear()


@functools.lru_cache(maxsize=8)
def _rules(m: tuple[int, ...], n_samples: int, tail: int) -> tuple[NDArray[np.float64], ...]:
    """Lags, weights and level indices of the quadrature of V1 for every pair ``i <= j``.

    Each pair's lags from its lowest to its highest break are summed segment by segment
    (``[a, b)`` between consecutive breaks), then its last break alone. A segment of up to
    :data:`DIRECT_LAGS` lags is summed lag by lag; a longer one by
    ``f(a) + int_a^b f - (f(a+) + f(b-)) / 2`` (Euler-Maclaurin for the lags strictly
    inside), the integral by Gauss-Legendre on pieces whose widths double from each end
    (:func:`_pieces`), the one-sided limits taken :data:`INSIDE` lags inside the ends,
    since a quantization term makes ``f`` jump at the kinks. The pieces of every segment
    are evaluated in one pass (the same operations as one segment at a time, bit for bit).
    """
    counts = [n_samples - 2 * mm + 1 for mm in m]
    # the rule's blocks in order: ("direct", a, b), ("pieces", first piece, pieces, a, b)
    # and ("point", lag); the pieces' edges of every long segment, end to end
    blocks: list[tuple[int, ...]] = []
    lo_edges: list[float] = []
    hi_edges: list[float] = []
    pairs, sizes = [], []
    for i in range(len(m)):
        for j in range(i, len(m)):
            mi, mj, ci, cj = m[i], m[j], counts[i], counts[j]
            lo = max(-2 * mj - tail, -(ci - 1))
            hi = min(2 * mi + tail, cj - 1)
            kinks = {pi - qj for pi in (0, mi, 2 * mi) for qj in (0, mj, 2 * mj)} | {0, cj - ci}
            breaks = sorted({lo, hi} | {k for k in kinks if lo < k < hi})
            size = 1
            for a, b in _segments(breaks):
                if b - a <= DIRECT_LAGS:
                    blocks.append((0, a, b))
                    size += b - a
                else:
                    edges = _pieces(a, b)
                    blocks.append((1, len(lo_edges), len(edges) - 1, a, b))
                    lo_edges.extend(edges[:-1])
                    hi_edges.extend(edges[1:])
                    size += (len(edges) - 1) * GL_POINTS + 3
            blocks.append((2, breaks[-1]))
            pairs.append((i, j))
            sizes.append(size)
    lo_p, hi_p = np.array(lo_edges)[:, None], np.array(hi_edges)[:, None]
    x = 0.5 * (hi_p - lo_p) * _GL_X[None, :] + 0.5 * (hi_p + lo_p)
    w = 0.5 * (hi_p - lo_p) * _GL_W[None, :]
    points: list[NDArray[np.float64]] = []
    weights: list[NDArray[np.float64]] = []
    ones = np.ones(DIRECT_LAGS)
    end_weights = np.array([1.0, -0.5, -0.5])
    for block in blocks:
        if block[0] == 0:
            a, b = block[1], block[2]
            points.append(np.arange(a, b, dtype=float))
            weights.append(ones[:b - a])
        elif block[0] == 1:
            first, n_pieces, a, b = block[1:]
            points.append(x[first:first + n_pieces].ravel())
            points.append(np.array([a, a + INSIDE, b - INSIDE]))
            weights.append(w[first:first + n_pieces].ravel())
            weights.append(end_weights)
        else:
            points.append(np.array([float(block[1])]))
            weights.append(ones[:1])
    k = np.concatenate(points)
    weight = np.concatenate(weights)
    pair_i = np.repeat([i for i, _ in pairs], sizes)
    pair_j = np.repeat([j for _, j in pairs], sizes)
    for arr in (k, weight, pair_i, pair_j):
        arr.flags.writeable = False
    return k, weight, pair_i, pair_j


def wv_covariance(
    model: GmwmModel,
    params: NDArray[np.float64],
    m: NDArray[np.int64],
    n_samples: int,
    sample_rate_hz: float,
) -> NDArray[np.float64]:
    """Covariance matrix ((deg/s)^4) of the empirical Haar WV at half-widths ``m`` under the model
    (V1).

    Parameters
    ----------
    model : GmwmModel
        The noise model.
    params : ndarray
        Its internal parameters (:mod:`analysis.gmwm.models`).
    m : ndarray of int
        Half-window lengths ``2^(j-1)`` of the levels.
    n_samples : int
        Record length N (``M_j = N - 2 m_j + 1`` coefficients per level).
    sample_rate_hz : float
        Sample rate in Hz.

    Returns
    -------
    ndarray, shape (len(m), len(m))
    """
    p = np.asarray(params, dtype=float)
    fs = float(sample_rate_hz)
    dt = 1.0 / fs
    m = np.asarray(m, dtype=np.int64)
    counts = n_samples - 2 * m + 1
    tail = _tail(model, p, int(m.max()), fs)
    k, weight, pair_i, pair_j = _rules(tuple(int(x) for x in m), int(n_samples), tail)
    mi, mj = m[pair_i].astype(float), m[pair_j].astype(float)
    s = np.zeros_like(k)
    for ip, ap in enumerate(_A):
        for iq, aq in enumerate(_A):
            s += ap * aq * model.structure(p, (k + iq * mj - ip * mi) * dt, dt)
    s *= -fs * fs / (8.0 * mi * mj)
    ci, cj = counts[pair_i].astype(float), counts[pair_j].astype(float)
    n_pairs = np.maximum(np.minimum(ci, cj - k) - np.maximum(0.0, -k), 0.0)
    terms = weight * n_pairs * s * s
    n_levels = len(m)
    sums: NDArray[np.float64] = np.bincount(pair_i * n_levels + pair_j, weights=terms,
                                            minlength=n_levels * n_levels).astype(float)
    cov = sums.reshape(n_levels, n_levels) * 2.0 / np.outer(counts, counts)
    out: NDArray[np.float64] = np.triu(cov) + np.triu(cov, 1).T
    return out
