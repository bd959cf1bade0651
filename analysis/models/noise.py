"""Power-law noise generators for the five IEEE gyro noise terms (one-shot, seeded).

The second half of the module designs the streaming form of flicker noise: a bank of
Gauss-Markov processes (:func:`flicker_bank`) and its exact discretization as sample
means (:func:`sample_bank`), which :mod:`analysis.models.simulation` runs chunk by chunk.

Each one-shot generator returns a rate error in deg/s sampled at ``sample_rate_hz``, shaped
``(n_samples,)`` or ``(n_samples, n_axes)``, drawn only from the ``rng`` passed in. The
coefficients are in SI-like base units (deg, s); :mod:`analysis.units` converts from the
data-sheet units. The Allan variance each one produces is that of IEEE Std 952-1997,
Annex C, and of Lv et al. 2015, eq. 3 (checked by Monte Carlo in the tests).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan.curves import as_tau, gauss_markov_avar
from analysis.allan.estimators import check_sample_rate


def _shape(n_samples: int, n_axes: int | None) -> tuple[int, ...]:
    if n_samples < 1:
        raise ValueError(f"n_samples must be >= 1, got {n_samples}")
    return (n_samples,) if n_axes is None else (n_samples, n_axes)


def white_angle_noise(
    q_deg: float, n_samples: int, sample_rate_hz: float, rng: np.random.Generator,
    *, n_axes: int | None = None,
) -> NDArray[np.float64]:
    """Quantization noise: white angle noise of std ``Q`` (deg), as a rate (deg/s).

    The rate is the first difference of a white angle sequence of standard deviation Q
    divided by the sample period; its Allan variance is ``3 Q^2 / tau^2`` at every
    ``tau = m / fs`` (Lv 2015 eq. 3, first term).
    """
    fs = check_sample_rate(sample_rate_hz)
    shape = _shape(n_samples + 1, n_axes)
    angle = q_deg * rng.standard_normal(shape)
    return np.diff(angle, axis=0) * fs


def white_rate_noise(
    n_deg_rt_s: float, n_samples: int, sample_rate_hz: float, rng: np.random.Generator,
    *, n_axes: int | None = None,
) -> NDArray[np.float64]:
    """Angle random walk: white rate noise with ARW coefficient ``N`` in deg/sqrt(s).

    Sample standard deviation ``N * sqrt(fs)`` (deg/s); Allan variance ``N^2 / tau``.
    """
    fs = check_sample_rate(sample_rate_hz)
    return np.asarray(n_deg_rt_s * np.sqrt(fs) * rng.standard_normal(_shape(n_samples, n_axes)),
                      dtype=np.float64)


def kasdin_coefficients(alpha: float, length: int) -> NDArray[np.float64]:
    """Impulse response of the fractional-differencing filter ``(1 - z^-1)^(-alpha/2)``.

    ``h_0 = 1, h_k = h_{k-1} (alpha/2 + k - 1) / k`` (N. J. Kasdin, "Discrete simulation
    of colored noise and stochastic processes and 1/f^alpha power law noise generation",
    Proc. IEEE 83(5), 1995, eq. 116).
    """
    k = np.arange(1, length, dtype=float)
    h = np.empty(length)
    h[0] = 1.0
    h[1:] = np.cumprod((alpha / 2.0 + k - 1.0) / k)
    return h


def flicker_rate_noise(
    b_deg_s: float, n_samples: int, sample_rate_hz: float, rng: np.random.Generator,
    *, n_axes: int | None = None,
) -> NDArray[np.float64]:
    """Bias instability: flicker (1/f) rate noise whose Allan plateau is ``0.664 B``.

    Kasdin's fractional-differencing filter (alpha = 1) applied to white noise of
    variance ``B^2``. Its one-sided PSD is ``2 B^2 dt / (2 sin(pi f dt))`` which tends to
    ``B^2 / (pi f)``, i.e. IEEE 952's two-sided ``B^2 / (2 pi f)``, whose Allan variance
    is ``(2 ln 2 / pi) B^2 = (0.664 B)^2``. The filter is exact at every frequency the
    record resolves (no corner below ``1 / T``), which a finite bank of Gauss-Markov
    processes only approximates.
    """
    check_sample_rate(sample_rate_hz)
    shape = _shape(n_samples, n_axes)
    white = b_deg_s * rng.standard_normal(shape)
    h = kasdin_coefficients(1.0, n_samples)
    from scipy import signal  # here: a simulator process never needs it (a second's import)

    if white.ndim == 1:
        return np.asarray(signal.fftconvolve(white, h)[:n_samples], dtype=np.float64)
    return np.asarray(signal.fftconvolve(white, h[:, None], axes=0)[:n_samples], dtype=np.float64)


def random_walk_rate_noise(
    k_deg_s_1_5: float, n_samples: int, sample_rate_hz: float, rng: np.random.Generator,
    *, n_axes: int | None = None,
) -> NDArray[np.float64]:
    """Rate random walk with coefficient ``K`` in deg/s^1.5: Allan variance ``K^2 tau / 3``.

    The rate integrates white noise of std ``K / sqrt(fs)`` per sample.
    """
    fs = check_sample_rate(sample_rate_hz)
    steps = k_deg_s_1_5 / np.sqrt(fs) * rng.standard_normal(_shape(n_samples, n_axes))
    return np.cumsum(steps, axis=0)


def rate_ramp(
    r_deg_s2: float, n_samples: int, sample_rate_hz: float, *, n_axes: int | None = None,
) -> NDArray[np.float64]:
    """Rate ramp ``R t`` with ``R`` in deg/s^2: Allan variance ``R^2 tau^2 / 2``."""
    fs = check_sample_rate(sample_rate_hz)
    t = np.arange(n_samples) / fs
    ramp = r_deg_s2 * t
    return ramp if n_axes is None else np.repeat(ramp[:, None], n_axes, axis=1)


# ------------------------------------------------- flicker noise as a bank of Gauss-Markov


@dataclass(frozen=True)
class MarkovBank:
    """A sum of independent first-order Gauss-Markov rates with a white and a random-walk tail.

    Attributes
    ----------
    sigma : ndarray, shape (n_poles,)
        Stationary standard deviation of each Gauss-Markov rate in deg/s.
    correlation_s : ndarray, shape (n_poles,)
        Correlation time of each in s.
    white_n : float
        Coefficient of an added white rate noise in deg/sqrt(s) (Allan variance N^2/tau).
    walk_k : float
        Coefficient of an added rate random walk in deg/s^1.5 (Allan variance K^2 tau/3).
    """

    sigma: NDArray[np.float64]
    correlation_s: NDArray[np.float64]
    white_n: float = 0.0
    walk_k: float = 0.0

    def avar(self, tau_s: ArrayLike) -> NDArray[np.float64]:
        """Allan variance of the bank in (deg/s)^2: the sum of its parts' closed forms."""
        tau = as_tau(tau_s)
        total = self.white_n**2 / tau + self.walk_k**2 * tau / 3.0
        for s, t in zip(self.sigma, self.correlation_s, strict=True):
            total = total + gauss_markov_avar(tau, float(s), float(t))
        return total


def flicker_bank(
    b_deg_s: float, sample_rate_hz: float, *, floor_hz: float = 1e-8,
    poles_per_decade: float = 2.0, ceiling_factor: float = 3.0,
) -> MarkovBank:
    """Gauss-Markov bank whose Allan variance is the flicker plateau ``(0.664 B)^2``.

    Corner frequencies ``f_i = floor_hz r^i`` (``r = 10^(1/poles_per_decade)``) up to the
    first above ``ceiling_factor * sample_rate_hz``, each pole of the same variance
    ``s^2 = B^2 ln(r) / pi``. Derivation: a pole of variance ``s^2`` and correlation time
    ``T = 1/(2 pi f_c)`` has the two-sided PSD ``2 s^2 T / (1 + (2 pi f T)^2)``; summed over
    poles spread evenly in ``ln f_c`` (``1/ln r`` per unit) it is
    ``(2 s^2 / ln r) int_0^inf dT / (1 + (2 pi f T)^2) = s^2 / (2 f ln r)``, equal to the
    bias-instability PSD ``B^2 / (2 pi f)`` of IEEE Std 952-1997 when
    ``s^2 = B^2 ln(r) / pi``; the Allan variance is then ``(2 ln 2 / pi) B^2`` (Zhang 2015
    eq. 9) between the corners, rippling by +-0.007 % at two poles per decade. The
    poles missing above the top corner act as white noise of ``N^2 = s^2 / (pi f_top (r-1))``
    and those missing below the floor as a rate random walk of
    ``K^2 = 4 pi s^2 f_floor / (r - 1)``; both tails are added, so the plateau holds
    within 0.1 % for ``1/fs <= tau <= 0.01 / floor_hz`` (tested).

    Parameters
    ----------
    b_deg_s : float
        Bias instability B in deg/s.
    sample_rate_hz : float
        Sample rate in Hz (sets the top corner).
    floor_hz : float
        Lowest corner frequency in Hz (default 1e-8: the plateau holds to tau = 1e6 s).
    poles_per_decade : float
        Pole density (2 gives +-0.007 % ripple, 1 gives +-2 %).
    ceiling_factor : float
        Top corner at this multiple of the sample rate.

    Returns
    -------
    MarkovBank
    """
    fs = check_sample_rate(sample_rate_hz)
    if not (b_deg_s >= 0 and math.isfinite(b_deg_s)):
        raise ValueError(f"bias instability must be finite and >= 0, got {b_deg_s}")
    if not (0 < floor_hz < ceiling_factor * fs) or not poles_per_decade > 0:
        raise ValueError(
            f"need 0 < floor_hz < ceiling_factor * fs and poles_per_decade > 0, got "
            f"{floor_hz}, {ceiling_factor}, {poles_per_decade}"
        )
    ratio = 10.0 ** (1.0 / poles_per_decade)
    n_poles = int(math.ceil(math.log(ceiling_factor * fs / floor_hz) / math.log(ratio))) + 1
    corners = floor_hz * ratio ** np.arange(n_poles)
    s2 = b_deg_s**2 * math.log(ratio) / math.pi
    return MarkovBank(
        sigma=np.full(n_poles, math.sqrt(s2)),
        correlation_s=1.0 / (2.0 * math.pi * corners),
        white_n=math.sqrt(s2 / (math.pi * corners[-1] * (ratio - 1.0))),
        walk_k=math.sqrt(4.0 * math.pi * s2 * floor_hz / (ratio - 1.0)),
    )


@dataclass(frozen=True)
class SampledBank:
    """Exact discrete form of a :class:`MarkovBank` observed as averages over each sample.

    Pole ``i`` has a state ``x`` (the rate at the start of a sample) that steps as
    ``x' = a x + e1`` (``e1 ~ N(0, innovation^2)``); the sample's mean rate is
    ``c x + g e1`` plus a part independent of everything else. Those independent parts of
    all poles (and the white tail) are summed into one normal draw of std ``shared``.
    A random-walk pole has ``a = 1``. The initial state is drawn with std ``initial``
    (the stationary std; 0 for the random walk, which starts at 0).
    """

    a: NDArray[np.float64]
    c: NDArray[np.float64]
    g: NDArray[np.float64]
    innovation: NDArray[np.float64]
    initial: NDArray[np.float64]
    shared: float


def _ou_moments(h: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """Per unit variance: a, Var(e1), Cov(e1, mean), Var(mean | x) of an OU over dt = h T."""
    a = np.exp(-h)
    v1 = -np.expm1(-2.0 * h)
    cov = np.expm1(-h) ** 2 / h
    hs = np.minimum(h, 1e-2)
    hl = np.maximum(h, 1e-2)
    f_series = hs**3 / 3 - hs**4 / 4 + 7 * hs**5 / 60 - hs**6 / 24
    f_closed = hl + 2.0 * np.expm1(-hl) - np.expm1(-2.0 * hl) / 2.0
    v2 = 2.0 * np.where(h < 1e-2, f_series, f_closed) / h**2
    return a, v1, cov, v2


def sample_bank(bank: MarkovBank, sample_rate_hz: float) -> SampledBank:
    """Exact discretization of a Gauss-Markov bank averaged over each sample period.

    For an Ornstein-Uhlenbeck rate ``dx = -x/T dt + q dW`` of variance ``s^2`` and a
    sample period ``dt = h T``: ``a = e^-h``; the innovation ``e1 = x(dt) - a x(0)`` has
    variance ``s^2 (1 - a^2)``; the sample mean is ``c x(0) + m`` with ``c = (1 - a)/h``
    and ``m = (qT/dt) int_0^dt (1 - e^(-(dt-u)/T)) dW(u)``, ``Var(m) = 2 s^2 F(h)/h^2``
    with ``F(h) = h - 2(1 - e^-h) + (1 - e^-2h)/2`` and ``Cov(e1, m) = s^2 (1 - a)^2 / h``.
    Then ``m = g e1 + r`` with ``g = Cov/Var(e1)`` and ``r`` independent of variance
    ``Var(m) - Cov^2/Var(e1)``. For the random walk (``T -> inf``): ``a = c = 1``,
    ``g = 1/2``, ``Var(r) = K^2 dt / 12`` (the Brownian bridge). Averages of the result
    over m samples are exact time averages of the continuous process, so its Allan
    variance equals :meth:`MarkovBank.avar` at every ``tau = m dt``.
    """
    fs = check_sample_rate(sample_rate_hz)
    dt = 1.0 / fs
    s2 = bank.sigma**2
    a, v1, cov, v2 = _ou_moments(dt / bank.correlation_s)
    g = cov / v1
    residual = s2 * np.maximum(v2 - cov * g, 0.0)
    shared = float(residual.sum()) + bank.white_n**2 * fs
    a_all, c_all, g_all = [a], [-np.expm1(-dt / bank.correlation_s) * bank.correlation_s / dt], [g]
    innov, initial = [np.sqrt(s2 * v1)], [bank.sigma.astype(float)]
    if bank.walk_k > 0:
        a_all.append(np.ones(1))
        c_all.append(np.ones(1))
        g_all.append(np.full(1, 0.5))
        innov.append(np.full(1, bank.walk_k * math.sqrt(dt)))
        initial.append(np.zeros(1))
        shared += bank.walk_k**2 * dt / 12.0
    return SampledBank(
        a=np.concatenate(a_all), c=np.concatenate(c_all), g=np.concatenate(g_all),
        innovation=np.concatenate(innov), initial=np.concatenate(initial),
        shared=math.sqrt(shared),
    )
