"""A FOG's stochastic error from two data-sheet indicators: ARW and bias stability.

The model (after Lv et al. 2014) is white rate noise plus a first-order Gauss-Markov
process, ``g_k = w_k + m_k``. From the angle random walk N, the bias stability S (the
standard deviation of the rate averaged over ``tau_a`` = 10 s or 100 s) and a
correlation time T, the white noise and the Markov process are fixed by the equations
derived in ``docs/fog-model.md``; the numbers below refer to that document:

* (F1) white noise std per sample ``sigma_w = N sqrt(fs)``;
* (F4) variance of a ``tau_a``-average of the Markov process
  ``sigma_m^2 * 2 (T/tau_a) [1 - (T/tau_a)(1 - exp(-tau_a/T))]``;
* (F5) ``S^2 = N^2 / tau_a + sigma_m^2 * phi(tau_a / T)``, solved for ``sigma_m``;
* (F6) the rule for T when none is given: ``T = tau_a``.

:func:`measure_bias_stability` and :func:`measure_arw` read the two indicators back off a
record, and :func:`bias_stability_statistics` gives the exact mean and spread of the
measured bias stability of a finite record (F7-F9), which the Monte Carlo tests compare
with.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan import blocks
from analysis.allan.estimators import check_sample_rate, overlapping_allan_variance
from analysis.errors import ModelError, TooFewSamplesError
from analysis.models.terms import AngleRandomWalk, GaussMarkov, NoiseModel
from analysis.units import conversions as units


def averaged_variance_factor(average_s: float, correlation_s: float) -> float:
    """Variance of a ``tau_a``-average of a unit-variance Gauss-Markov process (F4).

    ``phi = 2 (T/tau_a) [1 - (T/tau_a)(1 - exp(-tau_a/T))]``: 1 for T >> tau_a (the
    average keeps all the variance), ``2 T / tau_a`` for T << tau_a.

    Parameters
    ----------
    average_s : float
        Averaging time ``tau_a`` in s.
    correlation_s : float
        Correlation time T in s.
    """
    r = correlation_s / average_s
    x = average_s / correlation_s
    if x < 1e-4:
        return 1.0 - x / 3.0 + x**2 / 12.0
    return 2.0 * r * (1.0 - r * -math.expm1(-x))


@dataclass(frozen=True)
class FogParameters:
    """The white-noise-plus-Markov FOG model derived from ARW and bias stability.

    Attributes
    ----------
    arw_deg_rt_h : float
        Requested angle random walk N in deg/sqrt(h).
    bias_stability_deg_h : float
        Requested bias stability S (std of ``average_s`` averages) in deg/h.
    average_s : float
        Averaging time of the bias stability in s.
    correlation_s : float
        Correlation time T of the Markov process in s.
    markov_sigma_deg_h : float
        Stationary standard deviation of the Markov process in deg/h (F5).
    """

    arw_deg_rt_h: float
    bias_stability_deg_h: float
    average_s: float
    correlation_s: float
    markov_sigma_deg_h: float

    def white_sigma_deg_s(self, sample_rate_hz: float) -> float:
        """Standard deviation of the white rate noise per sample in deg/s (F1): ``N sqrt(fs)``."""
        fs = check_sample_rate(sample_rate_hz)
        return units.arw_deg_rt_h_to_deg_rt_s(self.arw_deg_rt_h) * math.sqrt(fs)

    def noise_model(self, name: str = "") -> NoiseModel:
        """The model as a :class:`NoiseModel` with ``[arw]`` and ``[gauss_markov]`` terms."""
        source = (f"FOG from ARW {self.arw_deg_rt_h} deg/sqrt(h) and bias stability "
                  f"{self.bias_stability_deg_h} deg/h ({self.average_s:g} s averages), "
                  f"T = {self.correlation_s:g} s; docs/fog-model.md")
        return NoiseModel(
            terms=(AngleRandomWalk(N_deg_rt_h=self.arw_deg_rt_h),
                   GaussMarkov(sigma_deg_h=self.markov_sigma_deg_h, tau_s=self.correlation_s)),
            name=name or "fog-two-indicators",
            source=source,
        )


def fog_from_indicators(
    arw_deg_rt_h: float, bias_stability_deg_h: float, *, average_s: float = 100.0,
    correlation_s: float | None = None,
) -> FogParameters:
    """Derive the FOG model's parameters from ARW and bias stability (docs/fog-model.md, F5).

    ``sigma_m^2 = (S^2 - N^2 / tau_a) / phi(tau_a/T)`` with ``phi`` of
    :func:`averaged_variance_factor` (F4); the white noise is N itself (F1).

    Parameters
    ----------
    arw_deg_rt_h : float
        Angle random walk N in deg/sqrt(h).
    bias_stability_deg_h : float
        Bias stability S in deg/h: the standard deviation of the rate averaged over
        ``average_s`` seconds, as a data sheet states it (1 sigma).
    average_s : float
        Averaging time of the bias stability in s (10 or 100 on most data sheets).
    correlation_s : float, optional
        Correlation time T of the Markov process in s; by default ``T = average_s``
        (rule F6: the Markov process then carries most of its variance into the
        average, ``phi(1) = 2/e = 0.74``, and its Allan deviation peaks at
        ``1.89 tau_a``, where data sheets read bias stability).

    Returns
    -------
    FogParameters

    Raises
    ------
    ModelError
        If a value is not finite and positive, or if the bias stability is not above
        the white noise's own share ``N / sqrt(tau_a)``.
    """
    for label, value in (("ARW", arw_deg_rt_h), ("bias stability", bias_stability_deg_h),
                         ("averaging time", average_s)):
        if not (math.isfinite(value) and value > 0):
            raise ModelError(f"{label} must be a finite positive number, got {value}")
    t_corr = float(average_s if correlation_s is None else correlation_s)
    if not (math.isfinite(t_corr) and t_corr > 0):
        raise ModelError(
            f"correlation time must be a finite positive number of s, got {correlation_s}"
        )
    n = units.arw_deg_rt_h_to_deg_rt_s(arw_deg_rt_h)
    s = units.rate_deg_h_to_deg_s(bias_stability_deg_h)
    white_share = n**2 / average_s
    if s**2 <= white_share:
        floor = units.rate_deg_s_to_deg_h(math.sqrt(white_share))
        raise ModelError(
            f"bias stability {bias_stability_deg_h} deg/h is not above what the ARW alone gives "
            f"for {average_s:g} s averages ({floor:.4g} deg/h = N / sqrt(tau_a)); "
            "raise it, lower the ARW or average longer"
        )
    sigma_m = math.sqrt((s**2 - white_share) / averaged_variance_factor(average_s, t_corr))
    return FogParameters(
        arw_deg_rt_h=float(arw_deg_rt_h), bias_stability_deg_h=float(bias_stability_deg_h),
        average_s=float(average_s), correlation_s=t_corr,
        markov_sigma_deg_h=units.rate_deg_s_to_deg_h(sigma_m),
    )


# ------------------------------------------------------------------------- measurement


def _average_counts(n_samples: int, sample_rate_hz: float, average_s: float) -> tuple[int, int]:
    m = int(round(average_s * sample_rate_hz))
    if m < 1:
        raise TooFewSamplesError(f"averaging time {average_s} s is shorter than a sample")
    j = n_samples // m
    if j < 2:
        raise TooFewSamplesError(
            f"{n_samples} samples hold {j} average(s) of {average_s} s; need at least 2"
        )
    return m, j


def measure_bias_stability(
    rate_deg_s: ArrayLike, sample_rate_hz: float, *, average_s: float = 100.0
) -> NDArray[np.float64]:
    """Bias stability of a record: std (ddof=1) of consecutive ``average_s`` averages.

    Parameters
    ----------
    rate_deg_s : array_like, shape (N,) or (N, k)
        Rate in deg/s.
    sample_rate_hz : float
        Sample rate in Hz.
    average_s : float
        Averaging time in s (rounded to whole samples); a trailing part is dropped.

    Returns
    -------
    ndarray, shape () or (k,)
        Bias stability in deg/h per axis.
    """
    fs = check_sample_rate(sample_rate_hz)
    rate = np.asarray(rate_deg_s, dtype=np.float64)
    m, j = _average_counts(rate.shape[0], fs, average_s)
    if blocks.is_long(rate.shape[0]):
        means = blocks.group_means(rate, m, j)  # a long record (a memmap): whole averages at a time
    else:
        means = rate[: m * j].reshape(j, m, *rate.shape[1:]).mean(axis=1)
    return np.asarray(units.S_PER_H * means.std(axis=0, ddof=1), dtype=np.float64)


def measure_arw(
    rate_deg_s: ArrayLike, sample_rate_hz: float, *, max_tau_s: float = 10.0
) -> NDArray[np.float64]:
    """Angle random walk of a record, fitted on the short-tau Allan variance.

    Fits ``avar(tau) = N^2 / tau + C tau`` (white rate plus the linear rise of slower
    terms) to the overlapping Allan variance on an octave grid ``1/fs <= tau <=
    max_tau_s``, by least squares on relative residuals (iteratively reweighted by the
    fitted curve, so each tau counts by its relative error).

    Parameters
    ----------
    rate_deg_s : array_like, shape (N,) or (N, k)
        Rate in deg/s.
    sample_rate_hz : float
        Sample rate in Hz.
    max_tau_s : float
        Largest averaging time of the fit in s.

    Returns
    -------
    ndarray, shape () or (k,)
        N in deg/sqrt(h) per axis.
    """
    fs = check_sample_rate(sample_rate_hz)
    rate = np.asarray(rate_deg_s, dtype=np.float64)
    m_max = int(min(max_tau_s * fs, rate.shape[0] // 10))
    if m_max < 2:
        raise TooFewSamplesError("record too short (or max_tau_s too small) to fit the ARW")
    taus = 2.0 ** np.arange(int(math.log2(m_max)) + 1) / fs
    res = overlapping_allan_variance(rate, fs, taus=taus)
    avar = res.avar if res.avar.ndim == 2 else res.avar[:, None]
    design = np.column_stack([1.0 / res.tau_s, res.tau_s])
    out = np.empty(avar.shape[1])
    for axis in range(avar.shape[1]):
        curve = avar[:, axis]
        for _ in range(3):
            w = 1.0 / np.maximum(curve, np.finfo(float).tiny)
            coef, *_ = np.linalg.lstsq(design * w[:, None], avar[:, axis] * w, rcond=None)
            curve = design @ coef
        out[axis] = math.sqrt(max(coef[0], 0.0))
    n_h = out * math.sqrt(units.S_PER_H)  # deg/sqrt(s) -> deg/sqrt(h), per axis
    return n_h if rate.ndim == 2 else cast(NDArray[np.float64], n_h[0])  # shape ()


@dataclass(frozen=True)
class BiasStabilityStatistics:
    """Exact mean and spread of the measured bias stability of a finite record.

    Attributes
    ----------
    mean_deg_h : float
        Expected measured bias stability in deg/h (to second order, F9).
    std_deg_h : float
        Its standard deviation over records in deg/h (F9).
    n_averages : int
        Number of averages in a record.
    """

    mean_deg_h: float
    std_deg_h: float
    n_averages: int


def bias_stability_statistics(
    params: FogParameters, duration_s: float, sample_rate_hz: float
) -> BiasStabilityStatistics:
    """Mean and spread of :func:`measure_bias_stability` on records of ``duration_s``.

    The J averages form a normal vector with Toeplitz covariance (F7)
    ``Sigma_ij = c(|i-j|)``, ``c(0) = N^2/tau_a + sigma_m^2 phi`` (F4) and
    ``c(k) = sigma_m^2 (T/tau_a)^2 (1 - e^(-tau_a/T))^2 e^(-(k-1) tau_a/T)``; the sample
    variance is the quadratic form ``s^2 = y' P y / (J-1)``, ``P = I - 11'/J``, with
    ``E s^2 = tr(P Sigma)/(J-1)`` and ``Var s^2 = 2 tr(P Sigma P Sigma)/(J-1)^2`` (F8),
    both summed over lags in O(J); the mean and std of ``s`` follow by the delta method
    (F9).

    Parameters
    ----------
    params : FogParameters
        The model.
    duration_s : float
        Record length in s.
    sample_rate_hz : float
        Sample rate in Hz (the averages are whole numbers of samples).

    Returns
    -------
    BiasStabilityStatistics
    """
    fs = check_sample_rate(sample_rate_hz)
    m, j = _average_counts(int(round(duration_s * fs)), fs, params.average_s)
    tau_a = m / fs
    t = params.correlation_s
    n = units.arw_deg_rt_h_to_deg_rt_s(params.arw_deg_rt_h)
    s2 = units.rate_deg_h_to_deg_s(params.markov_sigma_deg_h) ** 2
    x = tau_a / t
    lags = np.arange(1, j)
    c = np.empty(j)
    c[0] = n**2 / tau_a + s2 * averaged_variance_factor(tau_a, t)
    c[1:] = s2 * (t / tau_a) ** 2 * math.expm1(-x) ** 2 * np.exp(-(lags - 1) * x)
    weights = j - lags
    ones_sigma_ones = j * c[0] + 2.0 * np.sum(weights * c[1:])
    trace_sigma_sq = j * c[0] ** 2 + 2.0 * np.sum(weights * c[1:] ** 2)
    partial = np.concatenate([[0.0], np.cumsum(c[1:])])
    row_sums = c[0] + partial + partial[::-1]  # (Sigma 1)_i
    trace_p_sigma = j * c[0] - ones_sigma_ones / j
    trace_p_sigma_sq = trace_sigma_sq - 2.0 * np.sum(row_sums**2) / j + (ones_sigma_ones / j) ** 2
    mean_s2 = float(trace_p_sigma) / (j - 1)
    var_s2 = 2.0 * float(trace_p_sigma_sq) / (j - 1) ** 2
    mean_s = math.sqrt(mean_s2) * (1.0 - var_s2 / (8.0 * mean_s2**2))
    std_s = math.sqrt(var_s2) / (2.0 * math.sqrt(mean_s2))
    return BiasStabilityStatistics(
        mean_deg_h=units.rate_deg_s_to_deg_h(mean_s),
        std_deg_h=units.rate_deg_s_to_deg_h(std_s),
        n_averages=j,
    )
