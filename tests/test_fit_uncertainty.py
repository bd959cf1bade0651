"""Covariance of Allan values across taus, and the standard errors and term selection built on
it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.allan.confidence import allan_edf
from analysis.allan.covariance import covariance_basis
from analysis.allan.estimators import cluster_allan_variance, overlapping_allan_variance
from analysis.fit.least_squares import fit_every_method, fit_noise_terms
from analysis.models.noise import random_walk_rate_noise, white_angle_noise, white_rate_noise

M = np.array([1, 2, 3, 8, 32, 100, 256, 700])


def _mixture(n: int, rng: np.random.Generator) -> np.ndarray:
    """White angle (Q = 1), white rate (sigma 1 per sample) and a rate random walk, fs = 1 Hz."""
    return (white_angle_noise(1.0, n, 1.0, rng) + white_rate_noise(1.0, n, 1.0, rng)
            + random_walk_rate_noise(0.01, n, 1.0, rng))


def _allan_values(rate: np.ndarray, overlapping: bool) -> np.ndarray:
    """Allan variance at ``M`` (fs = 1 Hz) written out: squared second differences of the angle."""
    theta = np.concatenate([[0.0], np.cumsum(rate - rate.mean())])
    out = []
    for m in M:
        # cluster: the angle at whole clusters only
        t = theta if overlapping else theta[: (len(rate) // m) * m + 1 : m]
        lag = m if overlapping else 1
        d = t[2 * lag:] - 2 * t[lag:-lag] + t[:-2 * lag]
        out.append(np.mean(d**2) / (2.0 * m**2))
    return np.array(out)


@pytest.mark.parametrize("overlapping", [True, False])
def test_covariance_of_allan_values_matches_a_monte_carlo(overlapping: bool) -> None:
    """The analytic covariance across taus against 400 simulated records of 2048 samples."""
    n, runs = 2048, 400
    rng = np.random.default_rng(5)
    values = np.array([_allan_values(_mixture(n, rng), overlapping) for _ in range(runs)])
    beta = np.array([3.0, 1.0, 0.0, 0.01**2 / 3.0, 0.0])  # 3 Q^2, N^2, -, K^2/3 in (deg, s)
    basis = covariance_basis(M, n, 1.0, overlapping=overlapping)
    np.testing.assert_allclose(basis.mean(beta), values.mean(axis=0), rtol=0.06)
    model = basis.covariance(beta)
    measured = np.cov(values.T)
    # variance of a variance estimate over 400 runs: about +-10 % (heavier at long tau)
    ratio = np.diag(model) / np.diag(measured)
    assert np.all((ratio > 0.7) & (ratio < 1.4)), ratio
    sd, sd_m = np.sqrt(np.diag(model)), np.sqrt(np.diag(measured))
    corr, corr_m = model / np.outer(sd, sd), measured / np.outer(sd_m, sd_m)
    # a correlation from 400 runs scatters by about 1/sqrt(400) = 0.05
    assert np.max(np.abs(corr - corr_m)) < 0.2
    assert corr[0, 1] > 0.2 and corr[5, 6] > 0.2  # neighbouring taus share their samples


@pytest.mark.parametrize(("alpha", "beta"), [(0, [0, 1.0, 0, 0, 0]), (-2, [0, 0, 0, 1.0, 0])])
def test_one_noise_types_variance_gives_the_edf_of_the_confidence_module(
    alpha: int, beta: list
) -> None:
    n, m = 100_000, np.array([1, 10, 1000, 20_000, 40_000])
    basis = covariance_basis(m, n, 1.0, overlapping=True)
    rel = np.diag(basis.relative_covariance(np.array(beta, dtype=float)))
    edf = [allan_edf(int(n + 1 - 2 * k), int(k), alpha) for k in m]
    np.testing.assert_allclose(2.0 / rel, edf, rtol=0.03)


def test_paper_methods_standard_errors_follow_the_spread_on_the_every_m_grid() -> None:
    """OLS, WLS (Lv 2015 eq. 7, 14) and NNLS on the cluster every-m grid: their sandwich errors
    match the run-to-run spread (the formula errors are 10-1000x too small there)."""
    fs, n = 10.0, 18_000
    values: dict[str, list[float]] = {"ols": [], "wls": [], "nnls": []}
    errors: dict[str, list[float]] = {"ols": [], "wls": [], "nnls": []}
    for seed in range(6):
        rng = np.random.default_rng(seed)
        y = white_rate_noise(0.01, n, fs, rng) + random_walk_rate_noise(3e-4, n, fs, rng)
        fits = fit_every_method(cluster_allan_variance(y, fs, taus="all"), terms="NK")
        for method in values:
            values[method].append(fits[method].values["N"])
            errors[method].append(fits[method].stderr["N"])
            assert any("sandwich" in note for note in fits[method].notes)
    for method in values:
        ratio = np.mean(errors[method]) / np.std(values[method], ddof=1)
        # six runs give a spread to within a factor of about 1.7 (chi-square with 5 dof, 95 %)
        assert 0.45 < ratio < 2.2, (method, ratio)


def test_dropped_terms_are_zero_with_a_bound_and_said_in_the_notes() -> None:
    rng = np.random.default_rng(3)
    fit = fit_noise_terms(
        overlapping_allan_variance(white_rate_noise(0.01, 40_000, 10.0, rng), 10.0), method="logwls"
    )
    assert fit.terms == "N"
    assert fit.values["N"] == pytest.approx(0.01 * 60.0, rel=0.02)
    for term in "QBKR":
        assert fit.values[term] == 0.0 and fit.stderr[term] > 0
    d = fit.as_dict()
    assert d["terms"] == "N" and d["K_deg_h_1_5"] == 0.0
    assert any("not resolved" in note for note in d["notes"])
    assert math.isfinite(d["N_deg_rt_h_stderr"])
