"""Confidence intervals of the Allan family: noise identification by slope, edf, chi-square.

The equivalent degrees of freedom (edf) are computed, not looked up: a variance estimate
of the family is ``sum_i z_i^2 / (const L)`` over ``L`` terms ``z_i``, each a difference
of the angle (phase) ``theta``, and for a Gaussian power-law noise

    edf = 2 E[S]^2 / Var[S] = L^2 c(0)^2 / sum_{|i|<L} (L - |i|) c(i s)^2

where ``c(k)`` is the autocovariance of the terms at lag ``k`` samples and ``s`` the
spacing of the summed terms (1 for overlapping estimators, m for non-overlapping ones).
With ``R(j) = -D(j)/2`` the angle's generalized autocovariance (``D`` its structure
function), a d-th difference with step m (d = 2 Allan, 3 Hadamard) has
``c(k) = sum_q (-1)^q C(2d, d+q) R(k + q m)``; when the angles are first averaged over m
samples (modified Allan, time variance) ``R`` is replaced by ``W``, its discrete double
sum, and the weights by ``(-1)^q C(2d+2, d+1+q)``. Per rate-noise exponent alpha
(S_rate ~ f^alpha; the angle is the phase of frequency-stability work, the rate its
frequency):

* alpha = 2 (white angle, quantization): ``D(j) = 1`` for ``j != 0``;
* alpha = 1 (flicker angle): ``D(j) = g(j+1) - 2 g(j) + g(j-1)`` with ``g(t) = t^2 ln|t|``,
  a flicker phase averaged over one sample (the sampling model of Greenhall and Riley for
  the unmodified variances, their eq. 7-8 with F = m), so ``D`` grows as ``2 ln|j| + 3``;
* alpha = 0 (white rate, ARW): ``D(j) = |j|``;
* alpha = -1 (flicker rate, bias instability): ``D(j) = -j^2 ln|j|`` (the ``j^2`` term
  that depends on the low-frequency cut-off has a zero fourth difference);
* alpha = -2 (rate random walk): ``D(j) = -|j|^3``.

This is the approach of C. A. Greenhall and W. J. Riley, "Uncertainty of stability
variances based on finite differences", Proc. 35th PTTI (2003), with the lag sum taken
in full (sampled densely where ``c`` changes fast) instead of their truncated sum and
tables; it replaces the "simple" approximations of NIST SP 1065 Table 12, which
overstate the edf of the overlapping estimator at long tau (white rate noise at
``m = N/4``: 44 % coverage of a nominal 68 % interval in our Monte Carlo, 68 % with this).
For the overlapping Allan variance of white angle, white rate and rate random walk noise,
whose ``c`` is a piecewise polynomial of ``k/m``, the lag sum is taken in closed form
(:mod:`analysis.allan.edf_closed_form`, Euler-Maclaurin), at a cost independent of m.

The noise type per tau comes from :mod:`analysis.allan.noise_id` (lag-1 autocorrelation, as
Stable32) for the estimators of a whole record; :func:`local_noise_alpha` reads it off the
local slope of an Allan curve where only the curve is at hand (DAVAR windows), and cannot
tell flicker from white angle noise (both have slope -2).

scipy is imported where it is used: a simulated device's process imports this module
(through :mod:`analysis.allan.estimators`) and never needs scipy, whose import would cost
its start most of a second.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan.edf_closed_form import CLOSED_FORM_ALPHAS, overlapping_allan_edf_closed
from analysis.distributions import chi2_ppf

#: Confidence level of a +-1 sigma interval of a normal variable.
ONE_SIGMA = 0.6826894921370859
#: Rate-noise exponents the edf is computed for: white angle (2), flicker angle (1), white
#: rate (0), flicker rate (-1), rate random walk (-2).
NOISE_ALPHAS = (2, 1, 0, -1, -2)
#: Lags beyond this many m are dropped from the flicker sums (c(k) falls as k^-2 or faster).
FLICKER_LAG_LIMIT_M = 64
#: Lags per m at which a long overlapping lag sum is sampled (c(k) is smooth on that scale).
LAG_SAMPLES_PER_M = 64
#: Lag sums of up to this many lags are summed term by term.
DENSE_LAGS = 4096
#: Lags either side of 0 and of each multiple of m summed term by term in a sampled lag sum.
LAG_WINDOW = 64
#: Above this many taus, the edf is computed at this many and interpolated in log m.
EDF_EXACT_POINTS = 160


def local_noise_alpha(
    m: NDArray[np.int64], avar: NDArray[np.float64], n_samples: int | None = None
) -> NDArray[np.int64]:
    """Dominant power-law noise per tau, from the local log-log slope of the Allan variance.

    The slope ``mu`` of AVAR over about one octave either side of each m maps to the
    rate-noise exponent ``alpha``: mu = -2 -> 2 (white angle, quantization), -1 -> 0
    (white rate, ARW), 0 -> -1 (flicker rate, bias instability), +1 or more -> -2 (rate
    random walk, ramp). The slopes are then made non-decreasing in tau by a weighted
    isotonic regression (weights ``N / m``; ``N`` defaults to ``2 max(m)``), since the
    Allan variance of a sum of power-law noises is convex in log-log: a noisy long-tau
    estimate cannot turn the curve back to a steeper noise type. Returns an int array
    shaped like ``avar``.
    """
    if n_samples is None:
        n_samples = 2 * int(np.max(m))
    logm = np.log(np.asarray(m, dtype=float))
    loga = np.log(np.maximum(avar, np.finfo(float).tiny))
    if loga.ndim == 1:
        loga = loga[:, None]
    mu = np.full_like(loga, -1.0)
    if len(logm) >= 2:
        lo = np.maximum(logm - np.log(2), logm[0])
        hi = np.minimum(logm + np.log(2), logm[-1])
        span = np.where(hi > lo, hi - lo, 1.0)
        for c in range(loga.shape[1]):
            mu[:, c] = (np.interp(hi, logm, loga[:, c]) - np.interp(lo, logm, loga[:, c])) / span
        # the log-log slope of a sum of power laws never decreases with tau; the slopes
        # read off the noisy long-tau end are made to obey that, weighted by cluster count
        weights = np.maximum(np.asarray(n_samples // np.asarray(m), dtype=float), 1.0)
        from scipy import optimize  # scipy on first use: see the module's note on imports

        for c in range(loga.shape[1]):
            mu[:, c] = optimize.isotonic_regression(mu[:, c], weights=weights).x
    alpha = np.select([mu <= -1.5, mu <= -0.5, mu <= 0.5], [2, 0, -1], default=-2)
    return alpha.reshape(np.shape(avar)).astype(np.int64)


def _phase_acv(alpha: int, j: NDArray[np.float64]) -> NDArray[np.float64]:
    """Generalized autocovariance ``R(j) = -D(j)/2`` of the angle at lag ``j`` samples, up to the
    terms every estimator's difference filter cancels (a constant, and ``j^2`` for alpha <= -1)."""
    a = np.abs(j)
    if alpha == 2:
        return np.asarray(a == 0, dtype=np.float64)
    if alpha == 1:
        # D(j) = g(j+1) - 2 g(j) + g(j-1), g(t) = t^2 ln|t|, written so that it keeps its
        # precision at large |j| (2 ln|j| plus two terms of about |j| that nearly cancel)
        with np.errstate(divide="ignore", invalid="ignore"):
            big = np.maximum(a, 2.0)
            far = (
                2 * np.log(big)
                + (big + 1) ** 2 * np.log1p(1 / big)
                + (big - 1) ** 2 * np.log1p(-1 / big)
            )
        return np.asarray(-0.5 * np.select([a == 0, a == 1], [0.0, 4 * np.log(2.0)], default=far),
                          dtype=np.float64)
    if alpha == 0:
        return -0.5 * a
    if alpha == -1:
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(a > 0, 0.5 * a**2 * np.log(a), 0.0)
    if alpha == -2:
        return 0.5 * a**3
    raise ValueError(
        f"no structure function for rate-noise exponent alpha={alpha}; use one of {NOISE_ALPHAS}"
    )


def _phase_acv_double_sum(alpha: int, j: NDArray[np.float64]) -> NDArray[np.float64]:
    """``W(j)`` whose second difference (step 1) is :func:`_phase_acv`: the box sum of m angles
    has the generalized autocovariance ``W(j+m) - 2 W(j) + W(j-m)``. Exact for the discrete
    processes, except flicker rate, where the continuous ``j^4 ln|j| / 24`` stands in."""
    a = np.abs(j)
    if alpha == 2:
        return 0.5 * a
    if alpha == 1:
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(a > 0, -0.5 * a**2 * np.log(a), 0.0)
    if alpha == 0:
        return -(a**3 - a) / 12.0
    if alpha == -1:
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(a > 0, a**4 * np.log(a) / 24.0, 0.0)
    if alpha == -2:
        return a**5 / 40.0 - a**3 / 24.0 + a / 60.0
    raise ValueError(
        f"no structure function for rate-noise exponent alpha={alpha}; use one of {NOISE_ALPHAS}"
    )


@lru_cache(maxsize=8)
def _filter_taps(order: int, modified: bool) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Offsets q (in units of m) and weights of the autocorrelation of the estimator's filter:
    ``(-1)^q C(2d, d+q)`` for a d-th difference, ``(-1)^q C(2d+2, d+1+q)`` once the angles are
    averaged over m first (the box's own autocorrelation is the second difference of W)."""
    half = order + 1 if modified else order
    q = np.arange(-half, half + 1)
    from scipy import special  # on first use (see the module's note)

    w = (-1.0) ** np.abs(q) * special.comb(2 * half, half + q)
    q.setflags(write=False)  # cached: shared by every call
    w.setflags(write=False)
    return q, w


def difference_autocovariance(
    alpha: int, m: int, lags: ArrayLike, *, order: int = 2, modified: bool = False
) -> NDArray[np.float64]:
    """Autocovariance (arbitrary scale) at ``lags`` samples of the terms an estimator squares.

    The terms are the ``order``-th difference with step m of the angle (``order=2``: Allan,
    3: Hadamard), or of the angle averaged over m samples (``modified=True``: modified Allan
    and time variance), for the rate-noise exponent ``alpha`` (see the module docstring).
    """
    k = np.asarray(lags, dtype=float)
    q, w = _filter_taps(order, modified)
    fn = _phase_acv_double_sum if modified else _phase_acv
    return np.asarray(np.sum(w[:, None] * fn(alpha, k[None, :] + (q * m)[:, None]), axis=0),
                      dtype=np.float64)


def second_difference_autocovariance(alpha: int, m: int, lags: ArrayLike) -> NDArray[np.float64]:
    """Autocovariance (arbitrary scale) of ``theta[n+2m] - 2 theta[n+m] + theta[n]`` at ``lags``."""
    return difference_autocovariance(alpha, m, lags)


def _lag_samples(count: int, m: int, reach: int) -> NDArray[np.int64]:
    """Lags 1..count at which a long lag sum is evaluated: every lag near 0 and near each
    multiple ``q m`` (q <= reach), where the autocovariance can change within a sample
    (white and flicker angle noise), log-spaced lags away from them, and every
    ``m / LAG_SAMPLES_PER_M``-th lag between."""
    step = max(1, m // LAG_SAMPLES_PER_M)
    # dense next to each centre, then log-spaced (a flicker-angle peak falls off as a log)
    side = np.unique(np.rint(np.geomspace(LAG_WINDOW, max(LAG_WINDOW, m), 2 * LAG_WINDOW)))
    near = np.concatenate([-side, np.arange(-LAG_WINDOW, LAG_WINDOW + 1), side]).astype(np.int64)
    centres = np.arange(reach + 1) * m
    lags = np.concatenate(
        [(centres[:, None] + near[None, :]).ravel(), np.arange(0, count, step), [count]]
    )
    return np.unique(lags[(lags >= 1) & (lags <= count)])


def _sampled_sum(lags: NDArray[np.int64], f: NDArray[np.float64]) -> float:
    """``sum_{k=lags[0]}^{lags[-1]} f(k)`` from samples at ``lags``: the trapezoid rule between
    samples plus half of each end value (Euler-Maclaurin), exact where the samples are dense."""
    gaps = np.diff(lags)
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * gaps) + 0.5 * (f[0] + f[-1]))


def difference_edf(
    n_terms: int, m: int, alpha: int, *, order: int = 2, modified: bool = False, stride: int = 1
) -> float:
    """Equivalent degrees of freedom of one variance estimate (see the module docstring).

    Parameters
    ----------
    n_terms : int
        Number of squared terms summed, ``L``.
    m : int
        Averaging factor (samples per tau).
    alpha : int
        Rate-noise exponent, one of 2, 1, 0, -1, -2.
    order : int
        Order of the difference: 2 (Allan family) or 3 (Hadamard).
    modified : bool
        True when the angles are averaged over m before differencing (modified Allan, time).
    stride : int
        Spacing in samples of the summed terms: 1 overlapping, ``m`` non-overlapping.
    """
    if n_terms < 1:
        return 1.0
    reach = order + 1 if modified else order
    max_lag = FLICKER_LAG_LIMIT_M * m if alpha in (1, -1) else (reach + 1) * m
    count = min(n_terms - 1, max_lag // stride)
    c0 = float(difference_autocovariance(alpha, m, [0], order=order, modified=modified)[0])
    if count == 0:
        tail = 0.0
    else:
        if stride > 1 or count <= DENSE_LAGS:
            lags = np.arange(1, count + 1) * stride
        else:
            lags = _lag_samples(count, m, reach)
        f = (n_terms - lags // stride) * difference_autocovariance(
            alpha, m, lags, order=order, modified=modified) ** 2
        tail = float(np.sum(f)) if stride > 1 or count <= DENSE_LAGS else _sampled_sum(lags, f)
    denom = n_terms * c0**2 + 2.0 * tail
    if denom <= 0:
        return float(n_terms)
    return float(min(max(n_terms**2 * c0**2 / denom, 1.0), n_terms))


def allan_edf(n_terms: int, m: int, alpha: int, *, stride: int = 1) -> float:
    """edf of one Allan variance estimate: :func:`difference_edf` with ``order=2``, in closed
    form for the overlapping estimator (``stride=1``) of white angle, white rate and rate
    random walk noise (:func:`analysis.allan.edf_closed_form.overlapping_allan_edf_closed`,
    as :func:`allan_edf_grid` takes it)."""
    if stride == 1 and alpha in CLOSED_FORM_ALPHAS:
        return float(overlapping_allan_edf_closed(n_terms, m, alpha))
    return difference_edf(n_terms, m, alpha, stride=stride)


def estimator_terms(
    n_samples: int,
    m: ArrayLike,
    *,
    order: int = 2,
    modified: bool = False,
    overlapping: bool = True,
) -> NDArray[np.int64]:
    """Number of squared terms an estimator sums over ``N`` samples (``N + 1`` angles) at each m.

    Overlapping: ``N + 1 - order m`` (``N + 2 - (order + 1) m`` when modified); non-overlapping:
    ``floor(N / m) - order + 1``.
    """
    m = np.asarray(m, dtype=np.int64)
    if modified:
        return n_samples + 2 - (order + 1) * m
    if overlapping:
        return n_samples + 1 - order * m
    return n_samples // m - order + 1


def difference_edf_grid(
    n_samples: int,
    m: NDArray[np.int64],
    alpha: NDArray[np.int64],
    *,
    order: int = 2,
    modified: bool = False,
    overlapping: bool = True,
) -> NDArray[np.float64]:
    """edf of every (tau, axis) cell of a result: ``m`` (n_tau,), ``alpha`` (n_tau, k).

    The overlapping Allan variance's edf of white angle, white rate and rate random walk
    noise is taken in closed form at every tau
    (:func:`analysis.allan.edf_closed_form.overlapping_allan_edf_closed`: the same lag sum,
    equal to :func:`difference_edf` within 1e-14 relative where that sums every lag, within
    2.5e-4 where it samples them, and exact there). Otherwise, with more than
    ``EDF_EXACT_POINTS`` taus, the edf of each noise type is computed at a log-spaced
    subset of m and interpolated in log-log (it is smooth in m).
    """
    m = np.asarray(m, dtype=np.int64)
    alpha = np.asarray(alpha).reshape(len(m), -1)
    n_terms = estimator_terms(n_samples, m, order=order, modified=modified, overlapping=overlapping)
    if len(m) > EDF_EXACT_POINTS:
        picks = np.unique(np.geomspace(1, len(m), EDF_EXACT_POINTS).astype(int) - 1)
    else:
        picks = np.arange(len(m))
    out = np.empty(alpha.shape)
    closed = order == 2 and not modified and overlapping
    for a in np.unique(alpha):
        mask = alpha == a
        if closed and a in CLOSED_FORM_ALPHAS:
            # the same lag sum in closed form, at every tau (no interpolation)
            full = overlapping_allan_edf_closed(n_terms, m, int(a))
            out[mask] = np.broadcast_to(full[:, None], alpha.shape)[mask]
            continue
        # every tau that holds this type, or (interpolating) the picks that bracket them
        rows = np.flatnonzero(mask.any(axis=1))
        if len(picks) < len(m):
            lo = np.clip(np.searchsorted(picks, rows, side="right") - 1, 0, len(picks) - 1)
            rows = np.unique(picks[np.concatenate([lo, np.minimum(lo + 1, len(picks) - 1)])])
        exact = np.array(
            [
                difference_edf(
                    int(n_terms[i]),
                    int(m[i]),
                    int(a),
                    order=order,
                    modified=modified,
                    stride=1 if overlapping else int(m[i]),
                )
                for i in rows
            ]
        )
        if len(rows) == 1:
            full = np.full(len(m), exact[0])
        else:
            full = np.exp(np.interp(np.log(m), np.log(m[rows]), np.log(exact)))
        out[mask] = np.broadcast_to(full[:, None], alpha.shape)[mask]
    return np.clip(out, 1.0, np.maximum(n_terms, 1)[:, None])


def allan_edf_grid(
    n_samples: int, m: NDArray[np.int64], alpha: NDArray[np.int64], *, overlapping: bool
) -> NDArray[np.float64]:
    """edf of every (tau, axis) cell of an Allan result: :func:`difference_edf_grid`, order 2."""
    return difference_edf_grid(n_samples, m, alpha, overlapping=overlapping)


def chi2_interval(
    variance: ArrayLike, edf: ArrayLike, confidence: float = ONE_SIGMA
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two-sided chi-square confidence interval of a variance estimate with ``edf`` dof.

    ``low = v * edf / chi2.ppf((1 + c)/2, edf)``, ``high = v * edf / chi2.ppf((1 - c)/2, edf)``.
    """
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    v = np.asarray(variance, dtype=float)
    e = np.asarray(edf, dtype=float)
    # the quantiles depend on edf only; grids of every m repeat edf values many times
    unique, inverse = np.unique(e, return_inverse=True)
    upper = chi2_ppf(0.5 + confidence / 2, unique)[inverse].reshape(e.shape)
    lower = chi2_ppf(0.5 - confidence / 2, unique)[inverse].reshape(e.shape)
    return v * e / upper, v * e / lower


def overlapping_edf(n_samples: int, m: ArrayLike, alpha: ArrayLike) -> NDArray[np.float64]:
    """edf of overlapping Allan variances at averaging factors ``m`` for noise exponents ``alpha``.

    ``m`` has shape (n_tau,) or (n_tau, 1); ``alpha`` (n_tau,) or (n_tau, k). Returns the
    shape of ``alpha``. See :func:`allan_edf_grid`.
    """
    m_arr = np.asarray(m, dtype=np.int64).reshape(-1)
    a_arr = np.asarray(alpha)
    edf = allan_edf_grid(n_samples, m_arr, a_arr.reshape(len(m_arr), -1), overlapping=True)
    return edf.reshape(np.broadcast_shapes(a_arr.shape, (len(m_arr),) + (1,) * (a_arr.ndim - 1)))
