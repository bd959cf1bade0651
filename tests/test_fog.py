"""FOG model from ARW and bias stability: derivation checks and the Monte Carlo verification."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from analysis.errors import ModelError, TooFewSamplesError
from analysis.models.fog import (
    averaged_variance_factor,
    bias_stability_statistics,
    fog_from_indicators,
    measure_arw,
    measure_bias_stability,
)
from analysis.models.simulation import GyroSimulator
from analysis.models.terms import NoiseModel


def test_averaged_variance_factor_is_the_double_integral_of_the_correlation():
    for tau_a, t in ((10.0, 100.0), (100.0, 100.0), (100.0, 3.0), (1.0, 1e5)):
        # int_0^a int_0^a e^(-|u-v|/T) du dv = 2 int_0^a (a - u) e^(-u/T) du
        inner = 2 * integrate.quad(lambda u, a=tau_a, c=t: (a - u) * math.exp(-u / c), 0, tau_a,
                                   epsabs=0, epsrel=1e-12, limit=200)[0]
        assert averaged_variance_factor(tau_a, t) == pytest.approx(inner / tau_a**2, rel=1e-6)
    assert averaged_variance_factor(1.0, 1e9) == pytest.approx(1.0, rel=1e-8)
    assert averaged_variance_factor(1e6, 1.0) == pytest.approx(2e-6, rel=1e-5)


def test_derived_parameters_give_back_the_indicators_exactly():
    p = fog_from_indicators(0.01, 0.1, average_s=100.0, correlation_s=30.0)
    n_deg_rt_s = 0.01 / 60.0
    s_deg_s = p.markov_sigma_deg_h / 3600.0
    bias_stability_sq = n_deg_rt_s**2 / 100.0 + s_deg_s**2 * averaged_variance_factor(100.0, 30.0)
    assert math.sqrt(bias_stability_sq) * 3600.0 == pytest.approx(0.1, rel=1e-12)
    assert p.white_sigma_deg_s(100.0) == pytest.approx(n_deg_rt_s * 10.0)
    default_t = fog_from_indicators(0.01, 0.3, average_s=10.0)
    assert default_t.correlation_s == 10.0
    model = p.noise_model("unit")
    assert model.term_names == ("arw", "gauss_markov")
    assert NoiseModel.from_toml(model.to_toml()) == model


@pytest.mark.parametrize(
    ("args", "kwargs", "fragment"),
    [
        ((0.05, 0.5), {"average_s": 10.0}, "not above what the ARW alone gives"),
        ((0.0, 0.5), {}, "ARW must be"),
        ((0.01, -1.0), {}, "bias stability must be"),
        ((0.01, 0.1), {"correlation_s": 0.0}, "correlation time"),
        ((0.01, 0.1), {"average_s": math.inf}, "averaging time"),
    ],
)
def test_impossible_indicators_are_refused(args, kwargs, fragment):
    with pytest.raises(ModelError, match=fragment):
        fog_from_indicators(*args, **kwargs)


def test_bias_stability_statistics_equal_the_explicit_quadratic_form():
    params = fog_from_indicators(0.01, 0.3, average_s=10.0, correlation_s=25.0)
    stats = bias_stability_statistics(params, 400.0, 1.0)
    j, tau_a, t = 40, 10.0, 25.0
    s2 = (params.markov_sigma_deg_h / 3600) ** 2
    lag = np.abs(np.subtract.outer(np.arange(j), np.arange(j)))
    # covariance of the 10 s averages by direct numerical integration of e^(-|u-v|/T)
    cov = np.empty((j, j))
    for k in range(j):
        if k == 0:
            val = averaged_variance_factor(tau_a, t)
        else:
            val = integrate.quad(lambda u, k=k: (tau_a - abs(u - k * tau_a)) * math.exp(-u / t),
                                 (k - 1) * tau_a, (k + 1) * tau_a, epsrel=1e-12)[0] / tau_a**2
        cov[lag == k] = s2 * val
    cov += np.eye(j) * (0.01 / 60) ** 2 / tau_a
    p = (np.eye(j) - 1.0 / j) / (j - 1)
    mean_s2 = np.trace(p @ cov)
    var_s2 = 2 * np.trace(p @ cov @ p @ cov)
    assert stats.n_averages == j
    assert stats.mean_deg_h / 3600 == pytest.approx(
        math.sqrt(mean_s2) * (1 - var_s2 / (8 * mean_s2**2)), rel=1e-8
    )
    assert stats.std_deg_h / 3600 == pytest.approx(
        math.sqrt(var_s2) / (2 * math.sqrt(mean_s2)), rel=1e-8
    )


def test_measurements_refuse_records_too_short():
    with pytest.raises(TooFewSamplesError):
        measure_bias_stability(np.zeros(150), 1.0, average_s=100.0)
    with pytest.raises(TooFewSamplesError):
        measure_arw(np.zeros(10), 1.0)


# Typical conditions (ARW deg/sqrt(h), bias stability deg/h, averaging s, T s or None,
# sample rate Hz, record s): a navigation FOG (the data sheet of Zhang 2015's FOG), the
# VG951 of Lv 2015 with a tactical data-sheet bias stability, a low-grade FOG with a
# Markov time shorter than the average, and one with a longer one.
CONDITIONS = [
    (0.001, 0.007, 100.0, None, 1.0, 30000.0),
    (0.0076, 0.3, 10.0, None, 10.0, 3000.0),
    (0.05, 3.0, 10.0, 3.0, 10.0, 2000.0),
    (0.01, 0.1, 100.0, 300.0, 1.0, 60000.0),
]
RUNS = 100


@pytest.mark.parametrize("condition", CONDITIONS, ids=lambda c: f"arw{c[0]}-bs{c[1]}-avg{c[2]:g}")
def test_monte_carlo_indicators_of_simulated_runs_agree_with_the_requested_ones(condition):
    arw, bs, average_s, corr, fs, duration = condition
    params = fog_from_indicators(arw, bs, average_s=average_s, correlation_s=corr)
    sim = GyroSimulator(params.noise_model(), fs, n_axes=RUNS, seed=2014)  # 100 independent runs
    rate = sim.read(int(duration * fs)).rate_deg_s
    measured_bs = measure_bias_stability(rate, fs, average_s=average_s)
    measured_arw = measure_arw(rate, fs)
    assert measured_bs.shape == measured_arw.shape == (RUNS,)
    # the paper's check: the means agree with the requested values within 5 %
    assert measured_bs.mean() == pytest.approx(bs, rel=0.05)
    assert measured_arw.mean() == pytest.approx(arw, rel=0.05)
    # and with the exact expectation of a record this long, inside its band
    stats = bias_stability_statistics(params, duration, fs)
    assert abs(measured_bs.mean() - stats.mean_deg_h) < 4 * stats.std_deg_h / math.sqrt(RUNS)
    # the spread is the theoretical one (the sample std of 100 runs is known to ~7 %)
    assert measured_bs.std(ddof=1) == pytest.approx(stats.std_deg_h, rel=0.25)
    assert stats.std_deg_h > 0.01 * bs
