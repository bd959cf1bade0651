"""Power-law noise generators for the five IEEE gyro noise terms (one-shot, seeded).

Each generator returns a rate error in deg/s sampled at ``sample_rate_hz``, shaped
``(n_samples,)`` or ``(n_samples, n_axes)``, drawn only from the ``rng`` passed in. The
coefficients are in SI-like base units (deg, s); :mod:`analysis.units` converts from the
data-sheet units. The Allan variance each one produces is that of IEEE Std 952-1997,
Annex C, and of Lv et al. 2015, eq. 3 (checked by Monte Carlo in the tests).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from analysis.allan import check_sample_rate


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
    return n_deg_rt_s * np.sqrt(fs) * rng.standard_normal(_shape(n_samples, n_axes))


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
    if white.ndim == 1:
        return signal.fftconvolve(white, h)[:n_samples]
    return signal.fftconvolve(white, h[:, None], axes=0)[:n_samples]


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
