"""Closed-form Allan variances of rate signals: Gauss-Markov, sinusoid, warm-up transient.

Pure functions of the averaging time used by the noise model terms
(:mod:`analysis.models`) and by the simulator's flicker bank (:mod:`analysis.models.noise`).
All return Allan variances in (rate unit)^2 for averaging times in s.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.errors import InvalidTauError

#: Allan variance plateau of flicker rate noise per B^2: 2 ln 2 / pi = 0.6643^2 (Zhang 2015 eq. 9).
FLICKER_AVAR_FACTOR = 2.0 * math.log(2.0) / math.pi


def as_tau(tau_s: ArrayLike) -> NDArray[np.float64]:
    """Averaging times as a float array, refusing non-positive or non-finite values.

    Raises
    ------
    InvalidTauError
        If a tau is not a finite positive number of seconds.
    """
    tau = np.asarray(tau_s, dtype=np.float64)
    if not (np.all(np.isfinite(tau)) and np.all(tau > 0)):
        raise InvalidTauError(f"averaging times must be finite and > 0 s, got {tau_s!r}")
    return tau


def gauss_markov_avar(tau_s: ArrayLike, sigma: float,
                      correlation_s: float | NDArray[np.float64]) -> NDArray[np.float64]:
    """Allan variance of a first-order Gauss-Markov (exponentially correlated) rate.

    ``avar = 2 s^2 T / tau * [1 - T / (2 tau) (3 - 4 exp(-tau/T) + exp(-2 tau/T))]``
    (IEEE Std 952-1997, Annex C, with ``(q_c T)^2 = 2 s^2 T``), for a process of
    stationary standard deviation ``s`` and correlation time ``T``. It rises as
    ``2 s^2 tau / (3 T)`` (rate random walk) for tau << T and falls as ``2 s^2 T / tau``
    (white rate) for tau >> T. A series replaces the bracket for tau < 0.01 T, where the
    closed form loses its digits to cancellation.

    Parameters
    ----------
    tau_s : array_like
        Averaging times in s.
    sigma : float
        Stationary standard deviation in rate units (e.g. deg/s).
    correlation_s : float or ndarray
        Correlation time ``T`` in s (an array broadcasts against ``tau_s``).

    Returns
    -------
    ndarray
        Allan variance in (rate unit)^2, shaped like ``tau_s``.
    """
    tau = as_tau(tau_s)
    x = tau / correlation_s
    xs = np.minimum(x, 1e-2)
    series = xs**2 / 3 - xs**3 / 4 + 7 * xs**4 / 60 - xs**5 / 24
    xl = np.maximum(x, 1e-2)
    closed = 1.0 - (-4.0 * np.expm1(-xl) + np.expm1(-2.0 * xl)) / (2.0 * xl)
    bracket = np.where(x < 1e-2, series, closed)
    return 2.0 * sigma**2 * correlation_s / tau * bracket


def sinusoid_avar(tau_s: ArrayLike, amplitude: float, period_s: float) -> NDArray[np.float64]:
    """Allan variance of a sinusoidal rate of amplitude ``A`` and period ``P``.

    ``avar = A^2 sin^4(pi tau / P) / (pi tau / P)^2`` (IEEE Std 952-1997, Annex C), the
    mean over the sinusoid's phase; zero at every whole number of periods.
    """
    tau = as_tau(tau_s)
    x = np.pi * tau / period_s
    return amplitude**2 * np.sin(x) ** 4 / x**2


def _window_mean(z: complex | NDArray[np.complex128], span: NDArray[np.float64]) -> Any:
    """Mean of ``exp(z t)`` over ``t in [0, span]``: ``(exp(z span) - 1) / (z span)``."""
    zs = np.asarray(z * span, dtype=np.complex128)
    small = np.abs(zs) < 1e-8
    safe = np.where(small, 1.0, zs)
    return np.where(small, 1.0 + zs / 2.0, np.expm1(safe) / safe)


def deterministic_avar(
    tau_s: ArrayLike, *, duration_s: float | None, warmup_amplitude: float = 0.0,
    warmup_s: float = 1.0, cycle_amplitude: float = 0.0, period_s: float = 1.0,
    phase_deg: float = 0.0,
) -> NDArray[np.float64]:
    """Allan variance of ``A exp(-t/W) + C sin(2 pi t / P + phi)`` over a record of length L.

    The tau-average of the rate starting at t differs from the next one by
    ``Delta(t) = D_w exp(-t/W) + Re(D_c exp(i w t))`` with
    ``D_w = -A W (1 - e^(-tau/W))^2 / tau``, ``w = 2 pi / P`` and
    ``D_c = 2 C sinc sin(w tau/2) exp(i (w tau + phi))``, ``sinc = sin(w tau/2)/(w tau/2)``.
    The overlapping Allan variance is half the mean of ``Delta^2`` over
    ``t in [0, L - 2 tau]``; every product is an exponential whose mean has a closed form,
    so the result is exact (up to the sum over samples being an integral). With
    ``duration_s=None`` (L -> inf) it is the phase-averaged sinusoid,
    ``C^2 sin^4(w tau/2) / (w tau/2)^2`` (IEEE Std 952-1997 Annex C).

    Parameters
    ----------
    tau_s : array_like
        Averaging times in s.
    duration_s : float or None
        Record length L in s; None for an endless record.
    warmup_amplitude, cycle_amplitude : float
        A and C in rate units (deg/s).
    warmup_s, period_s : float
        W and P in s.
    phase_deg : float
        phi in degrees.

    Returns
    -------
    ndarray
        Allan variance in (rate unit)^2; 0 where ``2 tau > L``.
    """
    tau = as_tau(tau_s)
    half = np.pi * tau / period_s
    sinc = np.sin(half) / half
    d_c = (
        2.0
        * cycle_amplitude
        * sinc
        * np.sin(half)
        * np.exp(1j * (2.0 * half + np.deg2rad(phase_deg)))
    )
    steady = np.asarray(np.abs(d_c) ** 2 / 4.0, dtype=np.float64)
    if duration_s is None:
        return steady
    span = np.maximum(float(duration_s) - 2.0 * tau, 0.0)
    w = 2.0 * np.pi / period_s
    d_w = -warmup_amplitude * warmup_s * (-np.expm1(-tau / warmup_s)) ** 2 / tau
    total = (d_w**2 * _window_mean(-2.0 / warmup_s, span).real
             + 2.0 * d_w * (d_c * _window_mean(1j * w - 1.0 / warmup_s, span)).real
             + np.abs(d_c) ** 2 / 2.0 + (d_c**2 * _window_mean(2j * w, span)).real / 2.0) / 2.0
    return np.where(2.0 * tau <= duration_s, total, 0.0)
