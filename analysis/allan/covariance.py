"""Covariance of Allan variance estimates at different taus, for a sum of the five IEEE terms.

Allan values on one record are strongly correlated: neighbouring taus reuse the same
samples. A fit that treats them as independent claims far more than the data hold (the
formula standard errors of ``ols``/``wls`` on the every-m grid cover the truth in 0 % of
runs). This module computes their covariance matrix for a given noise model.

Both estimators sum squared second differences of the cumulative angle,
``A_i = sum_a d_i[a]^2 / (2 tau_i^2 L_i)`` over ``L_i`` positions ``a`` spaced by ``s_i``
samples (``s = 1`` overlapping, ``s = m`` cluster). For Gaussian noise,
``Cov(x^2, y^2) = 2 Cov(x, y)^2 + 4 E[x] E[y] Cov(x, y)``, so

    Cov(A_i, A_j) = [2 sum_u n_ij(u) c_ij(u)^2 + 4 mu_i mu_j sum_u n_ij(u) c_ij(u)]
                    / (4 tau_i^2 tau_j^2 L_i L_j)

with ``c_ij(u)`` the covariance of ``d_i[a]`` and ``d_j[a + u]``, ``n_ij(u)`` the number of
position pairs at lag ``u`` and ``mu_i = R tau_i^2`` the constant second difference a rate
ramp adds (the ramp is deterministic, IEEE Std 952-1997 C.1.5). ``c_ij`` is the mixed
fourth difference of the angle's generalized covariance ``k(j) = -D(j)/2``:

    c_ij(u) = sum_{a,b in 0..2} w_a w_b k(u + b m_j - a m_i),   w = (1, -2, 1),

where the structure function ``D`` of each term (in samples, unit coefficient) is
``1 - delta_j`` (white angle, Q), ``|j|`` (white rate, N), ``-j^2 ln|j|`` (flicker rate,
B) and ``-|j|^3`` (rate random walk, K): the functions behind the edf of
:mod:`analysis.allan.confidence` (Greenhall and Riley, PTTI 2003), taken here at two different
m. Each term enters with the variance coefficient ``beta`` of Lv 2015 eq. 6, so the
covariance is a quadratic form in ``beta``: the lag sums are computed once per tau grid
(:func:`covariance_basis`) and any model's covariance is then a cheap contraction
(:meth:`CovarianceBasis.covariance`).

Lag sums run exactly over the lattice of lags when it is short (small m) and otherwise by
Gauss-Legendre quadrature between the kinks of ``c_ij`` and ``n_ij`` (exact for the
polynomial terms N and K; flicker's tail beyond the support, falling as ``u^-2``, is
integrated out to 64 m). For the cluster estimator at two different m the positions do not
share one lattice; ``n_ij(u)`` is then the overlap of the two spans divided by
``lcm(m_i, m_j)`` on lags that are multiples of ``gcd(m_i, m_j)``, exact on average.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: The random terms of eq. 3 whose lag sums are tabulated, in this order (R is deterministic).
RANDOM_TERMS = "QNBK"
#: Flicker's lag sum is cut at this many times the larger m (its c(u) falls as u^-2).
FLICKER_TAIL_M = 64
#: Lag lattices up to this many points are summed exactly, longer ones by quadrature.
EXACT_LAGS = 1024
#: Cluster pairs whose lags cycle through fewer periods than this have their position pairs
#: listed (:func:`_few_periods`, :func:`_near_lags`) instead of a uniform density of lags.
UNIFORM_PERIODS = 10
#: Positions of the finer set a crowded cluster pair lists (a systematic sample beyond).
NEAR_POSITIONS = 400
#: Pairs summed together by quadrature, and over their lattices (bounds a batch's memory).
QUADRATURE_CHUNK = 256
EXACT_CHUNK = 64
#: Cluster pairs with at most this many position pairs are enumerated exactly.
EXACT_PAIRS = 2_000
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
_W = np.array([1.0, -2.0, 1.0])
_TERM_INDEX = {t: i for i, t in enumerate(RANDOM_TERMS)}


def _mixed_difference(mi: ArrayLike, mj: ArrayLike, u: NDArray[np.float64]) -> NDArray[np.float64]:
    """``c_ij(u)`` of the N, B, K terms (unit coefficient): shape ``u.shape[:-1] + (3, n)``.

    The generalized covariances ``k = -D/2`` are ``-|x|/2`` (N), ``x^2 ln|x| / 2`` (B) and
    ``|x|^3 / 2`` (K).
    """
    out = np.zeros(u.shape[:-1] + (3, u.shape[-1]))
    mi, mj = np.asarray(mi, dtype=float), np.asarray(mj, dtype=float)
    # the same operations in the same order as -w|x|, w x^2 ln|x| and w x^2 |x| summed over
    # the nine (a, b), into buffers reused across them (the basis of a 100-tau grid calls
    # this on 10^6-element arrays)
    x = np.empty(np.broadcast_shapes(u.shape, np.shape(mj), np.shape(mi)))
    wx2, scratch = np.empty_like(x), np.empty_like(x)
    for a in range(3):
        for b in range(3):
            w = 0.5 * _W[a] * _W[b]
            np.add(u, b * mj - a * mi, out=x)
            np.abs(x, out=x)
            np.multiply(w, x, out=scratch)
            out[..., 0, :] -= scratch
            np.multiply(x, x, out=wx2)
            np.multiply(w, wx2, out=wx2)
            np.maximum(x, 1e-300, out=scratch)
            np.log(scratch, out=scratch)
            np.multiply(wx2, scratch, out=scratch)
            out[..., 1, :] += scratch
            np.multiply(wx2, x, out=scratch)
            out[..., 2, :] += scratch
    return out


def _nine_lags(mi: ArrayLike, mj: ArrayLike) -> NDArray[np.float64]:
    """The lags ``a m_i - b m_j`` (a, b in 0..2) where the terms of ``c_ij`` change form: (...,
    9)."""
    return np.stack([a * np.asarray(mi, dtype=float) - b * np.asarray(mj, dtype=float)
                     for a in range(3) for b in range(3)], axis=-1)


#: ``w_a w_b / 2`` in the order of :func:`_nine_lags`: white angle noise's c at those lags.
_SPIKE_VALUES = np.array([0.5 * _W[a] * _W[b] for a in range(3) for b in range(3)])


def _spikes(lags: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """White angle noise's c at each of the nine lags, coinciding lags merged (the first keeps it).

    Returns ``(value, first)``: the summed value at each lag and a mask of the first of
    each group of equal lags (the others are left out of the sums).
    """
    same = lags[..., :, None] == lags[..., None, :]
    value = same.astype(float) @ _SPIKE_VALUES
    first = np.argmax(same, axis=-1) == np.arange(lags.shape[-1])
    return value, first


def _span_overlap(u: NDArray[np.float64], ti: ArrayLike, tj: ArrayLike) -> NDArray[np.float64]:
    """Length of ``[0, ti) & [-u, tj - u)``: how much of the record holds both positions at lag
    u."""
    out: NDArray[np.float64] = np.maximum(
        0.0, np.minimum(ti, np.subtract(tj, u)) - np.maximum(0.0, -u))
    return out


def _sums(c: NDArray[np.float64], weight: NDArray[np.float64], lags: NDArray[np.float64],
          spike_weight: NDArray[np.float64], mi: ArrayLike, mj: ArrayLike
          ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """G2 (..., 4, 4) and G1 (..., 4) from N, B, K's c at weighted lags and Q's nine spikes.

    Leading axes (pairs) broadcast: ``c`` (..., 3, n_lags), ``weight`` (..., n_lags),
    ``lags`` and ``spike_weight`` (..., 9): the pair count at each spike (0 for repeats).
    """
    lead = weight.shape[:-1]
    g2 = np.zeros(lead + (4, 4))
    g1 = np.zeros(lead + (4,))
    cw = c * weight[..., None, :]
    g2[..., 1:, 1:] = np.einsum("...tk,...sk->...ts", cw, c)
    g1[..., 1:] = cw.sum(axis=-1)
    cq, first = _spikes(lags)
    qw = np.where(first, spike_weight, 0.0) * cq
    g2[..., 0, 0] = np.sum(qw * cq, axis=-1)
    cross = np.einsum("...tk,...k->...t", _mixed_difference(mi, mj, lags), qw)
    g2[..., 0, 1:] = cross
    g2[..., 1:, 0] = cross
    g1[..., 0] = np.sum(qw, axis=-1)
    return g2, g1


def _exact_lags(mi: int, mj: int, si: int, sj: int, li: int, lj: int
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The lattice of lags of one pair and the number of position pairs at each."""
    g = math.gcd(si, sj)
    if (si > 1 or sj > 1) and li * lj <= EXACT_PAIRS:
        # few clusters: count the position pairs at each lag exactly
        every = (np.arange(lj)[None, :] * sj - np.arange(li)[:, None] * si).ravel()
        found, counts = np.unique(every, return_counts=True)
        return found.astype(float), counts.astype(float)
    if _few_periods(si, sj, li, lj):
        return _near_lags(mi, mj, si, sj, li, lj)
    lcm = si * sj // g
    tail = FLICKER_TAIL_M * max(mi, mj)
    u = g * np.arange(
        math.ceil((-2 * mj - tail) / g), math.floor((2 * mi + tail) / g) + 1, dtype=float
    )
    return u, _span_overlap(u, li * si, lj * sj) / lcm


def _few_periods(si: ArrayLike, sj: ArrayLike, li: ArrayLike, lj: ArrayLike) -> NDArray[np.bool_]:
    """Cluster pairs whose lags do not fill their lattice evenly: the coarser positions run
    through fewer than :data:`UNIFORM_PERIODS` cycles of the finer one's phases
    (``s_fine / gcd``), so the lags crowd (near 0 when m_i is near m_j)."""
    si, sj, li, lj = (np.asarray(v, dtype=np.int64) for v in (si, sj, li, lj))
    g = np.gcd(si, sj)
    fine = np.minimum(si, sj)
    coarse_count = np.where(si <= sj, lj, li)
    return ((si > 1) | (sj > 1)) & (coarse_count * g < UNIFORM_PERIODS * fine)


def _near_lags(mi: int, mj: int, si: int, sj: int, li: int, lj: int
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Cluster pairs whose positions line up over the record (few periods of ``lcm``): every
    position pair within the support of ``c_ij`` is listed (weight 1 each, or a systematic
    sample of :data:`NEAR_POSITIONS` positions weighted up; for m_i near m_j
    the lags crowd near 0, which a uniform density misses), the flicker tail beyond it by
    quadrature at the uniform density."""
    # every k up to NEAR_POSITIONS of them, else a systematic sample (the lag pattern moves
    # smoothly with k), each standing for its share of the positions
    step = max(1, -(-li // NEAR_POSITIONS))
    k = np.arange(0, li, step)
    base = (k * si) // sj
    offsets = np.arange(-3, (2 * mi + 2 * mj) // sj + 3)
    ell = base[:, None] + offsets[None, :]
    u = (ell * sj - (k * si)[:, None]).astype(float)
    inside = (ell >= 0) & (ell < lj) & (u >= -2 * mj) & (u <= 2 * mi)
    support_u = u[inside]
    support_w = np.full(len(support_u), li / len(k))
    tail = FLICKER_TAIL_M * max(mi, mj)
    width = 2.0 * (mi + mj)
    steps = width * 2.0 ** np.arange(6)
    edges_hi = np.unique(np.clip(np.concatenate([[2.0 * mi], 2.0 * mi + steps, [2.0 * mi + tail]]),
                                 2.0 * mi, 2.0 * mi + tail))
    edges_lo = np.unique(
        np.clip(
            np.concatenate([[-2.0 * mj], -2.0 * mj - steps, [-2.0 * mj - tail]]),
            -2.0 * mj - tail,
            -2.0 * mj,
        )
    )
    nodes, weights = [support_u], [support_w]
    for edges in (edges_hi, edges_lo):
        half = (edges[1:] - edges[:-1]) / 2.0
        mid = (edges[1:] + edges[:-1]) / 2.0
        tu = (mid[:, None] + half[:, None] * _GL_X).ravel()
        tw = (half[:, None] * _GL_W).ravel() * _span_overlap(tu, li * si, lj * sj) / (si * sj)
        nodes.append(tu)
        weights.append(tw)
    return np.concatenate(nodes), np.concatenate(weights)


def _exact_pairs(mi: NDArray[np.int64], mj: NDArray[np.int64], si: NDArray[np.int64],
                 sj: NDArray[np.int64], li: NDArray[np.int64], lj: NDArray[np.int64]
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lag sums of many pairs over their own lists of lags, summed pair by pair."""
    lists = [_exact_lags(*(int(v[k]) for v in (mi, mj, si, sj, li, lj))) for k in range(len(mi))]
    pair = np.repeat(np.arange(len(mi)), [len(u) for u, _ in lists])
    u = np.concatenate([u for u, _ in lists])
    weight = np.concatenate([w for _, w in lists])
    mi_f, mj_f = mi.astype(float), mj.astype(float)
    c = _mixed_difference(mi_f[pair], mj_f[pair], u)
    g2 = np.zeros((len(mi), 4, 4))
    g1 = np.zeros((len(mi), 4))
    for t in range(3):
        g1[:, 1 + t] = np.bincount(pair, c[t] * weight, minlength=len(mi))
        for r in range(t, 3):
            g2[:, 1 + t, 1 + r] = g2[:, 1 + r, 1 + t] = np.bincount(pair, c[t] * c[r] * weight,
                                                                     minlength=len(mi))
    # white angle noise: its nine spikes, each with the pair count the list holds at that lag
    lags = _nine_lags(mi_f, mj_f)
    spike_weight = np.array([[float(np.sum(w[uu == lag])) for lag in lags[k]]
                             for k, (uu, w) in enumerate(lists)])
    cq, first = _spikes(lags)
    qw = np.where(first, spike_weight, 0.0) * cq
    g2[:, 0, 0] = np.sum(qw * cq, axis=-1)
    cross = np.einsum("ptk,pk->pt", _mixed_difference(mi_f[:, None], mj_f[:, None], lags), qw)
    g2[:, 0, 1:] = cross
    g2[:, 1:, 0] = cross
    g1[:, 0] = np.sum(qw, axis=-1)
    return g2, g1


def _quadrature_pairs(mi: NDArray[np.int64], mj: NDArray[np.int64], si: NDArray[np.int64],
                      sj: NDArray[np.int64], li: NDArray[np.int64], lj: NDArray[np.int64]
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lag sums of many pairs at once by Gauss-Legendre quadrature between the kinks.

    A sum over the lattice of lags (spacing ``g = gcd(s_i, s_j)``, ``n(u)`` the span
    overlap over ``lcm(s_i, s_j)``) is the integral of the continuous lag function over
    ``g``; white angle noise stays a set of spikes.
    """
    def col(v: ArrayLike) -> NDArray[np.float64]:
        return np.asarray(v, dtype=float)[:, None]

    mi_f, mj_f = col(mi), col(mj)
    g = col(np.gcd(si, sj))
    lcm = col(si) * col(sj) / g
    ti, tj = col(li * si), col(lj * sj)
    support_lo, support_hi = -2.0 * mj_f, 2.0 * mi_f
    tail = FLICKER_TAIL_M * np.maximum(mi_f, mj_f)
    lo, hi = support_lo - tail, support_hi + tail
    doubling = (support_hi - support_lo) * 2.0 ** np.arange(6)[None, :]
    kinks = np.concatenate([_nine_lags(mi_f[:, 0], mj_f[:, 0]), np.zeros_like(ti), tj - ti, tj, -ti,
                            support_hi + doubling, support_lo - doubling, lo, hi], axis=1)
    edges = np.sort(np.clip(kinks, lo, hi), axis=1)
    half = (edges[:, 1:] - edges[:, :-1]) / 2.0
    mid = (edges[:, 1:] + edges[:, :-1]) / 2.0
    u = (mid[:, :, None] + half[:, :, None] * _GL_X).reshape(len(mi_f), -1)
    weight = (
        (half[:, :, None] * _GL_W).reshape(len(mi_f), -1) * _span_overlap(u, ti, tj) / (lcm * g)
    )
    lags = _nine_lags(mi_f[:, 0], mj_f[:, 0])
    spike_weight = _span_overlap(lags, ti, tj) / lcm
    return _sums(_mixed_difference(mi_f, mj_f, u), weight, lags, spike_weight, mi_f, mj_f)


@dataclass(frozen=True)
class CovarianceBasis:
    """Lag sums of every pair of taus of one grid; the covariance of any model follows.

    Attributes
    ----------
    tau_s : ndarray, shape (n,)
        Averaging times (s).
    m : ndarray of int, shape (n,)
        Averaging factors.
    n_terms : ndarray of int, shape (n,)
        Squared differences per value ``L`` (``N + 1 - 2m`` overlapping, ``N // m - 1`` cluster).
    sample_rate_hz : float
        Sample rate (Hz).
    g2 : ndarray, shape (n, n, 4, 4)
        ``sum_u n_ij(u) c_t(u) c_s(u)`` for t, s in Q, N, B, K (unit structure functions).
    g1 : ndarray, shape (n, n, 4)
        ``sum_u n_ij(u) c_t(u)`` (pairs with the rate ramp's constant second difference).
    """

    tau_s: NDArray[np.float64]
    m: NDArray[np.int64]
    n_terms: NDArray[np.int64]
    sample_rate_hz: float
    g2: NDArray[np.float64]
    g1: NDArray[np.float64]

    def _scales(self, beta: NDArray[np.float64]) -> NDArray[np.float64]:
        """Structure-function coefficient of Q, N, B, K (deg^2) from beta (eq. 6, base units)."""
        dt = 1.0 / self.sample_rate_hz
        b = np.where(np.isfinite(beta[:4]) & (beta[:4] > 0), beta[:4], 0.0)
        out: NDArray[np.float64] = b * np.array(
            [2.0 / 3.0, dt, dt**2 / (2.0 * math.log(2.0)), dt**3 / 2.0])
        return out

    def mean(self, beta: ArrayLike) -> NDArray[np.float64]:
        """Expected Allan variance ((deg/s)^2) of the model ``beta`` (QNBKR, eq. 6) on this grid."""
        b = np.where(np.isfinite(beta) & (np.asarray(beta) > 0), beta, 0.0)
        tau = self.tau_s
        out: NDArray[np.float64] = b[0] / tau**2 + b[1] / tau + b[2] + b[3] * tau + b[4] * tau**2
        return out

    def covariance(self, beta: ArrayLike, *, random_ramp: bool = False) -> NDArray[np.float64]:
        """Covariance ((deg/s)^4) of the Allan values for the model ``beta`` (QNBKR, eq. 6).

        Terms that are NaN or not positive contribute nothing. With ``random_ramp`` the
        ramp term is taken as a random rise of the same Allan variance (a rate random walk
        of ``K^2/3 = R^2 sqrt(tau_i tau_j)/2`` for each pair), whose values scatter as a
        random walk's do, instead of a deterministic ramp that adds a constant to every
        second difference: a model selection that compares terms by the shape of the
        curve must not credit a ramp with a precision the data cannot check.
        """
        beta = np.asarray(beta, dtype=float)
        q = self._scales(beta)
        ramp = beta[4] if np.isfinite(beta[4]) and beta[4] > 0 else 0.0
        tau = self.tau_s
        norm = 4.0 * np.outer(tau**2 * self.n_terms, tau**2 * self.n_terms)
        quad = np.einsum("ijts,t,s->ij", self.g2, q, q)
        if random_ramp:
            # the walk's coefficient of the pair (i, j) raised by r_ij: g2 is symmetric in
            # (t, s), so sum_ts g2 (q + r e_K)_t (q + r e_K)_s = q'g2 q + 2 r (g2 q)_K + r^2 g2_KK
            if ramp > 0:
                r = ramp * np.sqrt(np.outer(tau, tau)) / (2.0 * self.sample_rate_hz**3)
                quad = (quad + 2.0 * r * np.einsum("ijt,t->ij", self.g2[..., 3, :], q)
                        + r**2 * self.g2[..., 3, 3])
            random: NDArray[np.float64] = 2.0 * quad / norm
            return random
        mu = math.sqrt(2.0 * ramp) * tau**2
        lin = np.einsum("ijt,t->ij", self.g1, q)
        out: NDArray[np.float64] = (2.0 * quad + 4.0 * np.outer(mu, mu) * lin) / norm
        return out

    def relative_covariance(
        self, beta: ArrayLike, *, random_ramp: bool = False
    ) -> NDArray[np.float64]:
        """``Cov(A_i, A_j) / (E A_i E A_j)``: the covariance of the log values to first order."""
        mean = self.mean(beta)
        return self.covariance(beta, random_ramp=random_ramp) / np.outer(mean, mean)


def covariance_basis(
    m: ArrayLike, n_samples: int, sample_rate_hz: float, *, overlapping: bool
) -> CovarianceBasis:
    """Tabulate the lag sums of every pair of averaging factors ``m`` (see the module docstring).

    Parameters
    ----------
    m : array_like of int
        Averaging factors, each at most ``n_samples // 2``.
    n_samples : int
        Samples in the record.
    sample_rate_hz : float
        Sample rate (Hz).
    overlapping : bool
        True for the overlapping estimator, False for the cluster one.

    Returns
    -------
    CovarianceBasis

    Raises
    ------
    ValueError
        An averaging factor outside ``1 .. n_samples // 2``.
    """
    m = np.asarray(m, dtype=np.int64)
    if m.size == 0 or m.min() < 1 or m.max() > n_samples // 2:
        raise ValueError(
            f"averaging factors must lie in 1..{n_samples // 2} for {n_samples} samples"
        )
    n_terms = (n_samples + 1 - 2 * m) if overlapping else (n_samples // m - 1)
    stride = np.ones_like(m) if overlapping else m
    n = len(m)
    g2 = np.empty((n, n, 4, 4))
    g1 = np.empty((n, n, 4))
    i, j = np.triu_indices(n)
    si, sj, li, lj = stride[i], stride[j], n_terms[i], n_terms[j]
    lattice = (FLICKER_TAIL_M + 2) * 2 * np.maximum(m[i], m[j]) / np.gcd(si, sj)
    clusters = (si > 1) | (sj > 1)
    exact = (
        (lattice <= EXACT_LAGS)
        | (clusters & (li * lj <= EXACT_PAIRS))
        | _few_periods(si, sj, li, lj)
    )
    for picks, method, size in ((np.flatnonzero(exact), _exact_pairs, EXACT_CHUNK),
                                (np.flatnonzero(~exact), _quadrature_pairs, QUADRATURE_CHUNK)):
        for chunk in np.array_split(picks, max(1, len(picks) // size)):
            if len(chunk):
                g2[i[chunk], j[chunk]], g1[i[chunk], j[chunk]] = method(
                    m[i[chunk]], m[j[chunk]], si[chunk], sj[chunk], li[chunk], lj[chunk])
    # c_ji(u) = c_ij(-u): the lower triangle holds the same sums
    g2[j, i], g1[j, i] = g2[i, j], g1[i, j]
    return CovarianceBasis(
        m / float(sample_rate_hz), m, n_terms.astype(np.int64), float(sample_rate_hz), g2, g1
    )
