"""The closed-form edf of the overlapping Allan variance (white angle, white rate, rate random
walk) against the lag sum it replaces: the numeric :func:`difference_edf` where that sums
every lag (within 1e-13 relative), a brute-force sum of every lag where the numeric one
samples them (within 1e-13; the sampled sum is within 2.5e-4 of it), over records of 10 to
1e7 samples and m from 1 to N/2; and the lag-1 identification read in runs on a long record."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.allan.confidence import (
    DENSE_LAGS,
    allan_edf_grid,
    difference_autocovariance,
    difference_edf,
)
from analysis.allan.edf_closed_form import CLOSED_FORM_ALPHAS, overlapping_allan_edf_closed
from analysis.allan.estimators import cumulative_angle
from analysis.allan.noise_id import ACF_MAX_POINTS, identify_noise, lag1_alpha

RECORDS = (10, 11, 50, 257, 1000, 4096, 100_000, 2_000_000, 10_000_000)


def _grid(n: int) -> np.ndarray:
    return np.unique(np.rint(np.geomspace(1, n // 2, 40)).astype(np.int64))


def _brute_force_edf(n_terms: int, m: int, alpha: int) -> float:
    """Greenhall and Riley's lag sum over every lag (no sampling)."""
    lags = np.arange(1, min(n_terms - 1, 2 * m) + 1)
    c0 = difference_autocovariance(alpha, m, [0])[0]
    c = difference_autocovariance(alpha, m, lags)
    return float(n_terms**2 * c0**2 / (n_terms * c0**2 + 2 * np.sum((n_terms - lags) * c**2)))


@pytest.mark.parametrize("alpha", CLOSED_FORM_ALPHAS)
def test_closed_form_is_the_numeric_lag_sum(alpha: int) -> None:
    worst_dense = worst_sampled = 0.0
    for n in RECORDS:
        m = _grid(n)
        n_terms = n + 1 - 2 * m
        closed = overlapping_allan_edf_closed(n_terms, m, alpha)
        numeric = np.array([difference_edf(int(t), int(k), alpha)
                            for t, k in zip(n_terms, m, strict=True)])
        dense = np.minimum(n_terms - 1, 3 * m) <= DENSE_LAGS
        rel = np.abs(closed / numeric - 1)
        worst_dense = max(worst_dense, float(rel[dense].max(initial=0.0)))
        worst_sampled = max(worst_sampled, float(rel[~dense].max(initial=0.0)))
    assert worst_dense < 1e-13
    assert worst_sampled < 2.5e-4  # the numeric sum samples the lags there


@pytest.mark.parametrize("alpha", CLOSED_FORM_ALPHAS)
@pytest.mark.parametrize(("n", "m"), [(2_000_000, 3000), (2_000_000, 150_000),
                                      (10_000_000, 1_111_111), (1_000_000, 333_333),
                                      (1_000_000, 499_999)])
def test_closed_form_is_exact_where_the_numeric_sum_samples(alpha: int, n: int, m: int) -> None:
    n_terms = n + 1 - 2 * m
    exact = _brute_force_edf(n_terms, m, alpha)
    assert overlapping_allan_edf_closed(n_terms, m, alpha) == pytest.approx(exact, rel=1e-13)


def test_closed_form_clips_as_the_numeric_edf() -> None:
    assert overlapping_allan_edf_closed(0, 5, 0) == 1.0
    assert overlapping_allan_edf_closed(1, 5, -2) == 1.0
    with pytest.raises(ValueError, match="alpha=1"):
        overlapping_allan_edf_closed(100, 5, 1)


def test_grid_takes_the_closed_form_and_keeps_flicker_numeric() -> None:
    n = 100_000
    m = _grid(n)
    alpha = np.array([[2], [1], [0], [-1], [-2]])[np.arange(len(m)) % 5]
    grid = allan_edf_grid(n, m, alpha, overlapping=True)[:, 0]
    numeric = np.array([difference_edf(n + 1 - 2 * int(k), int(k), int(a))
                        for k, a in zip(m, alpha[:, 0], strict=True)])
    np.testing.assert_allclose(grid, numeric, rtol=2.5e-4)
    flicker = np.isin(alpha[:, 0], (1, -1))
    np.testing.assert_allclose(grid[flicker], numeric[flicker], rtol=1e-14)  # as before


def test_lag1_in_runs_reads_the_types_of_the_whole_series() -> None:
    """White rate and random-walk rate noise: the runs give the type the whole series does."""
    n = 3 * ACF_MAX_POINTS
    rng = np.random.default_rng(7)
    for rate, alpha in ((rng.standard_normal(n), 0), (np.cumsum(rng.standard_normal(n)), -2),
                        (np.diff(rng.standard_normal(n + 1)), 2)):
        theta = cumulative_angle(rate, 1.0)[:, 0]
        assert lag1_alpha(theta, 1) == alpha
        assert lag1_alpha(theta, 2) == alpha
    ident = identify_noise(cumulative_angle(rng.standard_normal(n), 1.0), np.array([1, 2, 3, 50]))
    assert ident.alpha[:, 0].tolist() == [0, 0, 0, 0]
