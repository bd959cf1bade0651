"""The edf of the overlapping Allan variance in closed form, for white angle, white rate and
rate random walk noise.

:func:`analysis.allan.confidence.difference_edf` sums Greenhall and Riley's lag sum
(C. A. Greenhall and W. J. Riley, "Uncertainty of stability variances based on finite
differences", Proc. 35th PTTI, 2003: an estimate of ``L`` terms ``z_i`` with autocovariance
``c(k)`` has ``1/edf = (1/L) sum_{|k|<L} (1 - |k|/L) (c(k)/c(0))^2``) a lag at a time, which
costs ``O(m)`` per tau (sampled above a few thousand lags). For the overlapping Allan
variance (second differences with step m, stride 1) of three of the five power-law noises,
``c(k)`` is a piecewise polynomial in ``u = k/m`` that vanishes from ``|k| = 2m`` on:

* white angle (alpha = 2, ``R(j) = delta(j)``): ``c(0) = 6``, ``c(m) = -4``, ``c(2m) = 1``,
  zero elsewhere;
* white rate (alpha = 0, ``R(j) = -|j|/2``): ``c(k) = m g(k/m)``, ``g(u) = 2 - 3u`` on
  [0, 1], ``u - 2`` on [1, 2];
* rate random walk (alpha = -2, ``R(j) = |j|^3/2``): ``c(k) = m^3 g(k/m)`` with ``g`` the
  cubic pieces of ``sum_q (-1)^q C(4, 2+q) |u + q|^3 / 2``.

So the lag sum ``T = sum_{k=1}^{K} (L - k) c(k)^2`` (``K = min(L - 1, 2m)``) is a sum of a
polynomial of degree at most 7 over whole ``k`` on each piece, which the Euler-Maclaurin
formula gives exactly with three Bernoulli terms:

    sum_{k=a}^{b} h(k/m) = m (H(b/m) - H(a/m)) + (h(a/m) + h(b/m))/2
                           + sum_{j=1}^{3} B_2j / (2j)! m^(1-2j) (h^(2j-1)(b/m) - h^(2j-1)(a/m))

(``H`` an antiderivative of ``h``, ``B_2 = 1/6``, ``B_4 = -1/30``, ``B_6 = 1/42``), and

    edf = L^2 c(0)^2 / (L c(0)^2 + 2 T)

the edf of Greenhall and Riley's lag sum taken in full, at a cost independent of m. Where
``L - 1 >= 2m`` this is their large-``r`` form ``1/edf = a0/r - a1/r^2`` (``r = L/m``) with
the ``a0``, ``a1`` of each m exactly rather than their limits. Flicker angle and flicker
rate noise, whose ``c(k)`` has logarithms and a tail, keep the lag sum of
:func:`analysis.allan.confidence.difference_edf`.
"""

from __future__ import annotations

from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from numpy.polynomial import Polynomial

#: Noise exponents whose overlapping Allan edf is taken in closed form here.
CLOSED_FORM_ALPHAS = (2, 0, -2)
#: Power-law angle structure per alpha: ``R(j) = scale |j|^power`` (as
#: :func:`analysis.allan.confidence._phase_acv`, up to the terms the difference cancels).
_POWER_LAW_ACV = {0: (1, -0.5), -2: (3, 0.5)}
#: Taps ``q`` and weights ``(-1)^q C(4, 2+q)`` of the second difference's autocorrelation.
_TAPS = (-2, -1, 0, 1, 2)
_WEIGHTS = (1.0, -4.0, 6.0, -4.0, 1.0)
#: Bernoulli numbers over factorials for the Euler-Maclaurin terms of derivative order 1, 3, 5.
_EM_TERMS = ((1, 1.0 / 12.0), (3, -1.0 / 720.0), (5, 1.0 / 30240.0))


@lru_cache(maxsize=4)
def _pieces(alpha: int) -> tuple[float, tuple[tuple[Polynomial, Polynomial], ...]]:
    """``g(0)`` and, per piece ``[i, i + 1]`` of ``u`` (i = 0, 1), ``g^2`` and ``u g^2``."""
    # on first use: a simulated device's process imports the estimators and never an edf
    from numpy.polynomial import Polynomial

    power, scale = _POWER_LAW_ACV[alpha]
    u = Polynomial([0.0, 1.0])
    pieces = []
    for i in (0, 1):
        g = Polynomial([0.0])
        for q, w in zip(_TAPS, _WEIGHTS, strict=True):
            sign = 1.0 if i + 0.5 + q > 0 else -1.0  # |x|^p = sign(x) x^p for odd p
            g = g + w * scale * sign * (u + q) ** power
        pieces.append((g * g, u * g * g))
    g0 = sum(w * scale * abs(q) ** power for q, w in zip(_TAPS, _WEIGHTS, strict=True))
    return float(g0), tuple(pieces)


def _em_sum(h: Polynomial, a: NDArray[np.float64], b: NDArray[np.float64],
            m: NDArray[np.float64]) -> NDArray[np.float64]:
    """``sum_{k=a}^{b} h(k/m)`` for polynomial ``h`` of degree <= 7, exactly (Euler-Maclaurin);
    0 where ``b < a``."""
    ua, ub = a / m, b / m
    integral = h.integ()
    total = m * (integral(ub) - integral(ua)) + 0.5 * (h(ua) + h(ub))
    for order, coeff in _EM_TERMS:
        dh = h.deriv(order)
        total = total + coeff * m ** (-order) * (dh(ub) - dh(ua))
    return np.where(b >= a, total, 0.0)


def overlapping_allan_edf_closed(n_terms: ArrayLike, m: ArrayLike, alpha: int
                                 ) -> NDArray[np.float64]:
    """edf of overlapping Allan variances of ``n_terms`` (``L = N + 1 - 2m``) squared second
    differences at averaging factors ``m``, for ``alpha`` in :data:`CLOSED_FORM_ALPHAS`.

    The same edf as :func:`analysis.allan.confidence.difference_edf` (``order=2``, stride 1),
    in closed form (see the module docstring): equal to rounding where that function sums
    every lag, and more exact where it samples the lags (``m`` of more than about 1400).
    Clipped to ``[1, L]`` as that function; ``L < 1`` gives 1.
    """
    big_l = np.asarray(n_terms, dtype=float)
    m_f = np.asarray(m, dtype=float)
    big_l, m_f = np.broadcast_arrays(big_l, m_f)
    valid = big_l >= 1
    big_l = np.where(valid, big_l, 1.0)
    if alpha == 2:
        lag_sum = 16.0 * np.maximum(big_l - m_f, 0.0) + np.maximum(big_l - 2.0 * m_f, 0.0)
        g0 = 6.0
    elif alpha in _POWER_LAW_ACV:
        g0, pieces = _pieces(alpha)
        last = np.minimum(big_l - 1.0, 2.0 * m_f)  # c(k) = 0 from |k| = 2m on
        lag_sum = np.zeros_like(big_l)
        for i, (g2, ug2) in enumerate(pieces):
            a = np.maximum(1.0, i * m_f + i)  # piece 0: k = 1..m; piece 1: k = m+1..2m
            b = np.minimum(last, (i + 1) * m_f)
            lag_sum += big_l * _em_sum(g2, a, b, m_f) - m_f * _em_sum(ug2, a, b, m_f)
    else:
        raise ValueError(
            f"no closed-form edf for alpha={alpha}; use one of {CLOSED_FORM_ALPHAS}")
    denom = big_l * g0**2 + 2.0 * lag_sum
    edf = np.where(denom > 0, big_l**2 * g0**2 / np.where(denom > 0, denom, 1.0), big_l)
    return np.where(valid, np.clip(edf, 1.0, big_l), 1.0)
