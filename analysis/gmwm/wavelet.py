"""Haar wavelet variance of gyro rate records: MODWT at dyadic scales, intervals, robust form.

The maximal-overlap discrete wavelet transform (MODWT) with the Haar filter has, at level
``j`` (``j = 1, 2, ...``), the coefficients

    W_{j,t} = (mean of m samples - mean of the next m samples) / 2,   m = 2^(j-1)     (W1)

at every start ``t`` (the level-j Haar filter is ``+-1/2^j`` over ``L_j = 2m`` taps;
Percival and Walden, *Wavelet Methods for Time Series Analysis*, 2000, eq. 169a and
section 5.4). Its averaging time is ``tau_j = m / fs = 2^(j-1) / fs``: 1/fs, 2/fs, 4/fs, ...
The unbiased MODWT estimator keeps only the ``M_j = N - L_j + 1`` coefficients free of the
boundary (PW eq. 306b):

    nu^2(tau_j) = (1 / M_j) sum_t W_{j,t}^2                                              (W2)

**Relation to the Allan variance.** With the cumulative angle ``theta`` (``N + 1`` points),
``W_{j,t} = (2 theta[t+m] - theta[t] - theta[t+2m]) / (2 tau)``, a second difference of
the angle over ``tau`` divided by ``2 tau``, while the overlapping Allan variance (Zhang
2015 eq. 5) is the mean square of the same second differences over ``2 tau^2`` and runs
over the same ``N + 1 - 2m = M_j`` terms. Hence, exactly (not only in expectation),

    nu^2(tau) = AVAR(tau) / 2      for the Haar filter at every tau = 2^(j-1) / fs       (W3)

and every term's wavelet variance is half its Allan variance (IEEE Std 952-1997 Annex C,
:mod:`analysis.models`). ``tests/test_wavelet.py`` checks W3 against
:func:`analysis.allan.overlapping_allan_variance`.

**Confidence intervals** (``ci=``):

``"pw"`` (default)
    chi-square with Percival and Walden's edf ``eta_1 = M_j nu^4 / A_j`` (PW eq. 313c),
    ``A_j`` the sum over all lags of the squared autocovariance of ``W_j``. Here ``A_j`` is
    estimated from the sample autocovariance over lags ``|tau| <= LAG_WIDTHS L_j`` (a lag
    window: the coefficients of white noise, quantization and random walks are
    uncorrelated beyond ``L_j``, those of flicker and Gauss-Markov noise decay), which
    keeps it free of the periodogram's bias that PW's halved all-lag sum corrects, and
    costs O(N) per level; beyond ``L_j = 8`` every ``L_j/8``-th lag and coefficient
    is used (the coefficients vary on the scale of ``L_j``).
``"eta3"``
    chi-square with PW's band-pass approximation ``eta_3 = max(M_j / 2^j, 1)`` (eq. 314c).
``"asymptotic"``
    normal, ``nu^2 +- z sqrt(2 A_j / M_j)`` (PW eq. 311 with the same ``A_j``).

**Robust form** (``robust=True``): the wavelet variance of each level is Huber's
"proposal 2" M-estimate of the scale of ``W_j`` about zero (Huber, *Robust Statistics*,
1981, section 5.6): the ``s`` with ``mean(min((W/s)^2, c^2)) = delta(c)``, ``delta(c) =
E[min(Z^2, c^2)]`` for a standard normal Z, so that it equals W2 in expectation for
Gaussian noise; ``c`` is set for a chosen efficiency at the Gaussian (default 0.6, as in
the robust GMWM of Balamuta et al., arXiv 1603.05297). A few outliers then move each
level's value by a bounded amount instead of by their square. Its variance is the
classical one over the efficiency.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan import blocks
from analysis.allan.confidence import ONE_SIGMA, chi2_interval
from analysis.allan.estimators import (
    as_samples,
    check_sample_rate,
    cumulative_angle,
    overlapping_sums,
)
from analysis.distributions import normal_cdf, normal_pdf, normal_ppf, normal_sf
from analysis.errors import TooFewSamplesError

CiMethod = Literal["pw", "eta3", "asymptotic"]
CI_METHODS: tuple[str, ...] = ("pw", "eta3", "asymptotic")
#: Lags of the autocovariance sum of ``A_j``, in filter widths ``L_j``.
LAG_WIDTHS = 4
#: Beyond this filter width, lags and coefficients are thinned to every ``L_j / LAG_THIN``-th.
LAG_THIN = 8
#: Most products averaged per autocovariance lag (the starts are thinned beyond it).
LAG_PRODUCTS = 1 << 17
#: Length of each block of starts when the products are thinned.
LAG_BLOCK = 4096
#: Default: the longest averaging time keeps ``N / m >= MIN_BLOCKS`` (four Haar windows).
MIN_BLOCKS = 8
#: Default efficiency of the robust estimate at Gaussian noise.
ROBUST_EFFICIENCY = 0.6
#: Iterations of the robust scale's fixed point (it converges linearly; 1e-10 relative).
ROBUST_MAX_ITER = 60


@dataclass(frozen=True)
class WaveletVariance:
    """Haar wavelet variance at dyadic averaging times.

    Attributes
    ----------
    tau_s : ndarray, shape (n_tau,)
        Averaging times ``2^(j-1) / fs`` in s.
    m : ndarray of int, shape (n_tau,)
        Samples per half Haar window, ``2^(j-1)``.
    wv : ndarray, shape (n_tau,) or (n_tau, k)
        Wavelet variance in (input unit)^2, e.g. (deg/s)^2; one column per axis.
    variance : ndarray, same shape as ``wv``
        Estimated variance of each ``wv`` value ((input unit)^4): ``2 A_j / M_j``, divided
        by the efficiency for the robust form.
    edf : ndarray, same shape as ``wv``
        Equivalent degrees of freedom behind the interval (``2 wv^2 / variance`` for
        ``"pw"`` and ``"asymptotic"``).
    ci_low, ci_high : ndarray, same shape as ``wv``
        Confidence interval of the wavelet variance at level ``confidence``.
    n_coefficients : ndarray of int, shape (n_tau,)
        Boundary-free MODWT coefficients ``M_j = N - 2m + 1``.
    confidence : float
        Two-sided level of the interval.
    ci : str
        ``"pw"``, ``"eta3"`` or ``"asymptotic"``.
    robust : bool
        Whether the values are the robust (Huber) estimate.
    sample_rate_hz : float
    n_samples : int
    """

    tau_s: NDArray[np.float64]
    m: NDArray[np.int64]
    wv: NDArray[np.float64]
    variance: NDArray[np.float64]
    edf: NDArray[np.float64]
    ci_low: NDArray[np.float64]
    ci_high: NDArray[np.float64]
    n_coefficients: NDArray[np.int64]
    confidence: float
    ci: str
    robust: bool
    sample_rate_hz: float
    n_samples: int

    @property
    def avar(self) -> NDArray[np.float64]:
        """The overlapping Allan variance at the same taus, ``2 wv`` (eq. W3)."""
        return 2.0 * self.wv

    def axis(self, index: int) -> WaveletVariance:
        """The result of one axis of a multi-axis result."""
        if self.wv.ndim == 1:
            if index != 0:
                raise IndexError(f"a single-axis result has no axis {index}")
            return self
        cols = {
            k: getattr(self, k)[:, index] for k in ("wv", "variance", "edf", "ci_low", "ci_high")
        }
        return WaveletVariance(tau_s=self.tau_s, m=self.m, n_coefficients=self.n_coefficients,
                               confidence=self.confidence, ci=self.ci, robust=self.robust,
                               sample_rate_hz=self.sample_rate_hz, n_samples=self.n_samples, **cols)


def dyadic_m(
    n_samples: int, *, min_blocks: int = MIN_BLOCKS, max_level: int | None = None
) -> NDArray[np.int64]:
    """Half-window lengths ``m = 2^(j-1)`` with ``m <= n_samples / min_blocks`` (and ``j <=
    max_level``)."""
    m_max = n_samples // min_blocks
    if m_max < 1:
        return np.zeros(0, dtype=np.int64)
    levels = int(math.floor(math.log2(m_max))) + 1
    if max_level is not None:
        levels = min(levels, max_level)
    return 2 ** np.arange(max(levels, 0), dtype=np.int64)


def haar_coefficients(
    theta: NDArray[np.float64], m: int, sample_rate_hz: float
) -> NDArray[np.float64]:
    """Boundary-free Haar MODWT coefficients (eq. W1) of one level from the angle ``theta`` (N+1,
    k)."""
    w = theta[m:-m] * 2.0
    w -= theta[: -2 * m]
    w -= theta[2 * m:]
    w *= sample_rate_hz / (2.0 * m)
    return w


def _lag_sum_long(theta: NDArray[np.float64], m: int, sample_rate_hz: float, width: int
                  ) -> NDArray[np.float64]:
    """:func:`_lag_sum` of the level-``m`` coefficients of a memory-mapped angle, each
    coefficient computed from the angle where the estimate reads it."""
    thin = max(1, width // LAG_THIN)
    n_w = theta.shape[0] - 2 * m

    def take(rows: NDArray[np.int64]) -> NDArray[np.float64]:
        t = np.asarray(rows, dtype=np.int64) * thin
        flat = t.reshape(-1)
        w = np.empty((len(flat), theta.shape[1]))
        # a gathered coefficient maps in up to three pages and the system's fault-around
        # their neighbours: hand them back each time the rows read span a block of the
        # angle (a few thousand rows of a wide level's thinned coefficients span all of it)
        per_release = max(1, min(LAG_BLOCK, blocks.BLOCK_SAMPLES // thin))
        for a, b in blocks.spans(0, len(flat), per_release):
            f = flat[a:b]
            w[a:b] = (2.0 * theta[f + m] - theta[f] - theta[f + 2 * m]) * (
                sample_rate_hz / (2.0 * m))
            blocks.release(theta)
        return w.reshape(*t.shape, theta.shape[1])

    return _thinned_lag_sum(take, -(-n_w // thin), theta.shape[1], thin, width)


def _lag_sum(w: NDArray[np.float64], width: int) -> NDArray[np.float64]:
    """``A = sum_{|l| <= LAG_WIDTHS width} c(l)^2`` per column of ``w`` (c: sample autocovariance).

    Width up to ``LAG_THIN``: every lag, summed. Wider: lags ``i d`` (``d = width /
    LAG_THIN``) and Simpson's rule over them, ``A = 2 int_0 c(l)^2 dl`` (exact for the
    piecewise-linear autocovariance of white-noise coefficients, whose kinks at ``width/2``
    and ``width`` fall on the grid). The coefficients are thinned like the lags; when more
    than ``LAG_PRODUCTS`` remain, each ``c(l)`` averages the products over
    ``LAG_PRODUCTS / LAG_BLOCK`` blocks spread evenly over the record (enough for a 1 %
    edf, at a fixed cost per level).
    """
    thin = max(1, width // LAG_THIN)
    x = w[::thin]
    return _thinned_lag_sum(lambda j: x[j], x.shape[0], x.shape[1], thin, width)


def _thinned_lag_sum(take: Callable[[NDArray[np.int64]], NDArray[np.float64]], n: int, k: int,
                     thin: int, width: int) -> NDArray[np.float64]:
    """:func:`_lag_sum` of the thinned coefficients ``x`` (``n`` rows, ``k`` columns, every
    ``thin``-th coefficient), read through ``take(rows)``: only the rows the estimate
    uses are asked for."""
    max_lag = min(LAG_WIDTHS * width // thin, n - 1)
    if thin > 1:
        max_lag -= max_lag % 2
    if n - max_lag <= LAG_PRODUCTS:
        x = take(np.arange(n))
        c = np.array(
            [np.einsum("ij,ij->j", x[: n - i], x[i:]) / (n - i) for i in range(max_lag + 1)]
        )
    else:
        n_blocks = LAG_PRODUCTS // LAG_BLOCK
        starts = np.linspace(0, n - LAG_BLOCK - max_lag, n_blocks).astype(np.int64)
        rows = take(starts[:, None] + np.arange(LAG_BLOCK + max_lag)[None, :])
        head = rows[:, :LAG_BLOCK]
        c = np.array(
            [
                np.einsum("bij,bij->j", head, rows[:, i : i + LAG_BLOCK]) / (n_blocks * LAG_BLOCK)
                for i in range(max_lag + 1)
            ]
        )
    c2 = c * c
    if thin == 1 or max_lag < 2:
        plain: NDArray[np.float64] = (c2[0] + 2.0 * c2[1:].sum(axis=0)) * thin
        return plain
    simpson = np.ones(max_lag + 1)
    simpson[1:-1:2], simpson[2:-1:2] = 4.0, 2.0
    out: NDArray[np.float64] = 2.0 * thin / 3.0 * (simpson[:, None] * c2).sum(axis=0)
    return out


def huber_delta(c: float) -> float:
    """``E[min(Z^2, c^2)]`` for a standard normal Z (consistency constant of proposal 2)."""
    return float(
        (2 * normal_cdf(c) - 1) - 2 * c * normal_pdf(c) + 2 * c**2 * normal_sf(c)
    )


def huber_efficiency(c: float) -> float:
    """Asymptotic efficiency at Gaussian data of the proposal-2 scale (vs the mean square).

    ``2 gamma^2 / Var(min(Z^2, c^2))`` with ``gamma = E[Z^2; |Z| < c]`` (the slope of the
    estimating equation), for independent Gaussian values.
    """
    p = 2 * normal_cdf(c) - 1
    phi = normal_pdf(c)
    gamma = p - 2 * c * phi
    fourth = 3 * p - 2 * phi * (c**3 + 3 * c) + c**4 * 2 * normal_sf(c)
    return float(2 * gamma**2 / (fourth - huber_delta(c) ** 2))


def huber_constant(efficiency: float) -> float:
    """The ``c`` whose proposal-2 scale has this Gaussian efficiency (0 < efficiency < 1)."""
    from scipy import optimize
    if not 0.05 < efficiency < 0.999:
        raise ValueError(f"robust efficiency must be in (0.05, 0.999), got {efficiency}")
    return float(optimize.brentq(lambda c: huber_efficiency(c) - efficiency, 0.05, 10.0))


def robust_scale2(w: NDArray[np.float64], c: float) -> float:
    """Huber proposal-2 estimate of ``E[W^2]`` of one column, about zero (module docstring).

    The root ``s2 > 0`` of ``f(s2) = mean(min(W^2, c^2 s2)) - delta s2``, concave with
    ``f(0) = 0`` and ``f'(0+) = c^2 > delta``, by Newton's method from the mean square
    (monotone after the first step).
    """
    delta = huber_delta(c)
    w2 = np.ascontiguousarray(w) ** 2
    s2 = float(w2.mean())
    if s2 <= 0:
        return 0.0
    for _ in range(ROBUST_MAX_ITER):
        cut = c * c * s2
        clipped = w2 > cut
        f = (float(np.where(clipped, cut, w2).sum()) / len(w2)) - delta * s2
        slope = c * c * float(np.count_nonzero(clipped)) / len(w2) - delta
        new = s2 - f / slope if slope < 0 else 2.0 * s2
        if abs(new - s2) <= 1e-12 * new:
            return new
        s2 = new
    return s2


def haar_wavelet_variance(
    samples: ArrayLike,
    sample_rate_hz: float,
    *,
    ci: CiMethod = "pw",
    confidence: float = ONE_SIGMA,
    robust: bool = False,
    efficiency: float = ROBUST_EFFICIENCY,
    min_blocks: int = MIN_BLOCKS,
    max_level: int | None = None,
    gaps: bool = False,
    angle_out: NDArray[np.float64] | None = None,
) -> WaveletVariance:
    """Haar MODWT wavelet variance (unbiased, eq. W2) at every dyadic averaging time.

    Parameters
    ----------
    samples : array_like, shape (N,) or (N, k)
        Rate samples, e.g. deg/s (each axis a column).
    sample_rate_hz : float
        Sample rate in Hz.
    ci : {"pw", "eta3", "asymptotic"}
        Interval: chi-square with Percival-Walden's edf (lag-window estimate of ``A_j``),
        with their band-pass edf, or the normal approximation (module docstring).
    confidence : float
        Two-sided level of the interval (default +-1 sigma).
    robust : bool
        Huber-type robust estimate instead of the mean square.
    efficiency : float
        Gaussian efficiency of the robust estimate (sets Huber's ``c``).
    min_blocks : int
        The longest averaging time has ``m <= N / min_blocks``.
    max_level : int, optional
        At most this many levels.
    gaps : bool
        NaN samples are missing (a record with gaps on its sample grid): only coefficients
        whose Haar window holds no missing sample count, ``M_j`` is their number and
        ``n_samples`` the number of samples present.
    angle_out : ndarray, shape (N + 1, k), optional
        A long record without gaps (:func:`analysis.allan.blocks.is_long`, e.g. a memmap), not
        robust: its angle is kept here (e.g. a memmap), the mean squares are the
        overlapping Allan sums (:func:`analysis.allan.kernels.overlapping_sums`, a block at a
        time) and the lag-window estimate reads only the coefficients it uses: bounded
        memory, the same numbers to rounding.

    Returns
    -------
    WaveletVariance
        In (input unit)^2; ``2 wv`` is the overlapping Allan variance at the same taus.

    Raises
    ------
    NonFiniteSamplesError, InvalidSampleRateError
        Bad samples or rate.
    TooFewSamplesError
        Fewer than ``2 min_blocks`` samples.
    ValueError
        Unknown ``ci`` or a bad ``confidence``/``efficiency``.

    References
    ----------
    Percival and Walden 2000, eq. 306b (estimator), 311 and 313c (edf); Guerrier et al.,
    J. Am. Stat. Assoc. 108 (2013) 776, section 2 (the Haar WV of the GMWM).
    """
    if ci not in CI_METHODS:
        raise ValueError(f"ci must be one of {', '.join(CI_METHODS)}, got {ci!r}")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    fs = check_sample_rate(sample_rate_hz)
    missing = None
    if gaps:
        raw = np.asarray(samples, dtype=np.float64)
        raw = raw[:, None] if raw.ndim == 1 else raw
        missing = np.isnan(raw)
        samples_in = np.where(missing, np.nanmean(raw, axis=0), raw)
        arr = as_samples(samples_in)
    else:
        arr = as_samples(samples)
    n = arr.shape[0]
    m_values = dyadic_m(n, min_blocks=min_blocks, max_level=max_level)
    if m_values.size == 0:
        raise TooFewSamplesError(f"{n} samples are too few for a wavelet variance; record at least "
                                 f"{2 * min_blocks}")
    c = huber_constant(efficiency) if robust else 0.0
    eff = huber_efficiency(c) if robust else 1.0
    long = angle_out is not None and missing is None and not robust and blocks.is_long(n)
    theta = cumulative_angle(arr, fs, out=angle_out if long else None)
    k = arr.shape[1]
    wv = np.empty((len(m_values), k))
    a_sum = np.empty((len(m_values), k))
    n_coef = (n - 2 * m_values + 1).astype(np.int64)
    if long:
        wv[:] = (overlapping_sums(theta, m_values) * (fs / (2.0 * m_values[:, None])) ** 2
                 / n_coef[:, None])
        for i, m in enumerate(int(v) for v in m_values):
            if ci != "eta3":
                a_sum[i] = _lag_sum_long(theta, m, fs, 2 * m)
    # missing samples in the window [t, t + 2m) of each coefficient, per column
    holes = (
        None if missing is None else np.concatenate([np.zeros((1, k)), np.cumsum(missing, axis=0)])
    )
    levels = len(m_values)
    for i, m in enumerate(m_values if not long else ()):
        w = haar_coefficients(theta, int(m), fs)
        share = np.ones(k)
        if holes is not None:
            bad = (holes[2 * m:] - holes[: -2 * m]) > 0
            count = (~bad).sum(axis=0)
            if count.min() == 0:
                # no gap-free window this long (nor longer): the record says nothing of
                # these levels, which end here rather than read as a wavelet variance of 0
                levels = i
                break
            w[bad] = 0.0
            n_coef[i] = int(count.min())
            share = count / w.shape[0]
        if robust:
            wv[i] = [
                robust_scale2(w[:, col] if holes is None else w[~bad[:, col], col], c)
                for col in range(k)
            ]
        else:
            wv[i] = np.einsum("ij,ij->j", w, w) / (w.shape[0] * share)
        if ci != "eta3":
            a_sum[i] = _lag_sum(w, 2 * int(m)) / share**2
    if levels == 0:
        raise TooFewSamplesError(f"no {2 * int(m_values[0])} consecutive samples without a gap: "
                                 "a wavelet variance needs gap-free windows")
    m_values, n_coef, wv, a_sum = m_values[:levels], n_coef[:levels], wv[:levels], a_sum[:levels]
    if missing is not None:
        n = int(n - missing.sum(axis=0).max())
    if ci == "eta3":
        edf = np.broadcast_to(np.maximum(n_coef / (2.0 * m_values), 1.0)[:, None], wv.shape).copy()
        variance = 2.0 * wv**2 / edf / eff
        edf = edf * eff
    else:
        variance = 2.0 * a_sum / n_coef[:, None] / eff
        edf = np.maximum(2.0 * wv**2 / np.maximum(variance, np.finfo(float).tiny), 1.0)
    if ci == "asymptotic":
        z = float(normal_ppf(0.5 + confidence / 2))
        half = z * np.sqrt(variance)
        low, high = np.maximum(wv - half, 0.0), wv + half
    else:
        low, high = chi2_interval(wv, edf, confidence)
    if np.ndim(samples) == 1:
        wv, variance, edf, low, high = wv[:, 0], variance[:, 0], edf[:, 0], low[:, 0], high[:, 0]
    return WaveletVariance(tau_s=m_values / fs, m=m_values, wv=wv, variance=variance, edf=edf,
                           ci_low=low, ci_high=high, n_coefficients=n_coef, confidence=confidence,
                           ci=ci, robust=robust, sample_rate_hz=fs, n_samples=n)
