"""Allan variance estimators: against allantools, the NBS14 reference set, and by property."""

from __future__ import annotations

import allantools
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from analysis.allan.estimators import (
    all_m,
    analysis_log_m,
    cluster_allan_variance,
    log_m,
    m_from_tau,
    octave_m,
    overlapping_allan_variance,
)
from analysis.allan.variance import allan_variance
from analysis.errors import (
    InvalidSampleRateError,
    InvalidTauError,
    NonFiniteSamplesError,
    TooFewSamplesError,
)
from analysis.models.noise import flicker_rate_noise, random_walk_rate_noise, white_rate_noise


def nbs14_1000() -> np.ndarray:
    """The NBS14 1000-point test set (NIST SP 1065, section 12.4): a MINSTD LCG, normalized."""
    n = [1234567890]
    for _ in range(999):
        n.append((16807 * n[-1]) % 2147483647)
    assert n[1:4] == [395529916, 1209410747, 633705974]  # first values printed in SP 1065
    return np.array(n, dtype=float) / 2147483647.0


# Published ADEV and OADEV of the NBS14 1000-point set at tau = 1, 10, 100 (rate 1 Hz),
# W. J. Riley, Handbook of Frequency Stability Analysis, NIST SP 1065, table 31; the same
# values allantools' test suite checks its adev/oadev against (Stable32 agrees).
NBS14_ADEV = [2.922319e-01, 9.965736e-02, 3.897804e-02]
NBS14_OADEV = [2.922319e-01, 9.159953e-02, 3.241343e-02]


def test_nbs14_adev_and_oadev_match_published_values() -> None:
    y = nbs14_1000()
    cluster = cluster_allan_variance(y, 1.0, taus=[1, 10, 100])
    overlapping = overlapping_allan_variance(y, 1.0, taus=[1, 10, 100])
    np.testing.assert_allclose(cluster.adev, NBS14_ADEV, rtol=2e-6)
    np.testing.assert_allclose(overlapping.adev, NBS14_OADEV, rtol=2e-6)


@pytest.mark.parametrize("n", [1000, 4097, 30011])
@pytest.mark.parametrize("grid", ["octave", "log"])
def test_matches_allantools_on_random_data(n: int, grid: str) -> None:
    rng = np.random.default_rng(n)
    y = rng.standard_normal(n) + np.cumsum(rng.standard_normal(n)) * 0.01 + 3.0
    fs = 12.5
    ours_o = overlapping_allan_variance(y, fs, taus=grid)
    _, ref_o, _, _ = allantools.oadev(y, rate=fs, data_type="freq", taus=ours_o.tau_s)
    np.testing.assert_allclose(ours_o.adev[: len(ref_o)], ref_o, rtol=1e-9)
    assert len(ref_o) >= len(ours_o.tau_s) - 1
    ours_c = cluster_allan_variance(y, fs, taus=grid)
    taus_ref, ref_c, _, _ = allantools.adev(y, rate=fs, data_type="freq", taus=ours_c.tau_s)
    keep = np.isin(ours_c.tau_s, taus_ref)
    np.testing.assert_allclose(ours_c.adev[keep], ref_c, rtol=1e-9)
    # angle increments (deg per sample) give the same Allan variance of the rate
    inc = overlapping_allan_variance(y / fs, fs, taus=grid, input_kind="angle_increment")
    np.testing.assert_allclose(inc.avar, ours_o.avar, rtol=1e-9)


def test_multi_axis_equals_axis_by_axis() -> None:
    rng = np.random.default_rng(5)
    y = rng.standard_normal((5000, 3)) * [1.0, 2.0, 0.5]
    both = overlapping_allan_variance(y, 100.0)
    assert both.avar.shape == (len(both.tau_s), 3)
    for k in range(3):
        single = overlapping_allan_variance(y[:, k], 100.0)
        np.testing.assert_allclose(both.axis(k).avar, single.avar, rtol=1e-12)
        np.testing.assert_allclose(both.axis(k).ci_high, single.ci_high, rtol=1e-12)


def test_all_m_cluster_grid_equals_direct_cluster_means() -> None:
    rng = np.random.default_rng(2)
    y = rng.standard_normal(3001)
    r = cluster_allan_variance(y, 2.0, taus="all")
    assert np.array_equal(r.m, np.arange(1, 1501))
    for m in (1, 2, 7, 100, 1000, 1500):
        j = len(y) // m
        means = y[: j * m].reshape(j, m).mean(axis=1)
        direct = np.sum(np.diff(means) ** 2) / (2 * (j - 1))
        assert r.avar[m - 1] == pytest.approx(direct, rel=1e-10)
        assert r.n_clusters[m - 1] == j
    # eq. 8: 1-sigma error of the root Allan variance
    np.testing.assert_allclose(r.relative_error, 1 / np.sqrt(2 * (r.n_clusters - 1)))


def test_tau_grids() -> None:
    assert list(octave_m(1000)) == [1, 2, 4, 8, 16, 32, 64, 128, 256]
    assert all_m(9)[-1] == 4
    m = log_m(10_000, n_points=100)
    assert m[0] == 1 and m[-1] <= 10_000 // 9  # eq. 20: at least 9 clusters
    assert np.all(np.diff(m) > 0)  # repeats removed after rounding
    assert len(m) < 100
    # the analysis grid: the same points, continued at that spacing to two clusters
    full = analysis_log_m(10_000)
    np.testing.assert_array_equal(full[: len(m)], m)
    assert full[-1] == 5000 and np.all(np.diff(np.log(full[len(m):])) < 0.1)
    ratio = log_m(10_000, ratio=1.073)  # the paper's example: tau_g = 1.073 for N = 1e4
    assert ratio[-1] <= 1111 and len(ratio) > 60
    np.testing.assert_array_equal(m_from_tau([0.1, 0.5, 0.1], 10.0), [1, 5])


def test_bad_input_is_refused_with_a_useful_message() -> None:
    y = np.ones(100)
    y[17] = np.nan
    with pytest.raises(NonFiniteSamplesError, match="sample 17"):
        overlapping_allan_variance(y, 10.0)
    with pytest.raises(InvalidSampleRateError):
        overlapping_allan_variance(np.ones(100), 0.0)
    with pytest.raises(InvalidSampleRateError):
        overlapping_allan_variance(np.ones(100), float("nan"))
    with pytest.raises(InvalidTauError, match="multiple of the sample period"):
        overlapping_allan_variance(np.ones(100), 10.0, taus=[0.15])
    with pytest.raises(TooFewSamplesError):
        overlapping_allan_variance(np.ones(100), 10.0, taus=[6.0])
    with pytest.raises(TooFewSamplesError):
        overlapping_allan_variance(np.ones(5), 10.0, taus="log")
    with pytest.raises(ValueError, match="estimator"):
        allan_variance(np.ones(100), 10.0, estimator="modified")


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    scale=st.floats(1e-6, 1e6),
    offset=st.floats(-1e3, 1e3),
    estimator=st.sampled_from(["overlapping", "clusters"]),
)
def test_scaling_and_offset_properties(
    seed: int, scale: float, offset: float, estimator: str
) -> None:
    y = np.random.default_rng(seed).standard_normal(700)
    base = allan_variance(y, 1.0, estimator=estimator, taus="octave")
    scaled = allan_variance(scale * y, 1.0, estimator=estimator, taus="octave")
    shifted = allan_variance(y + offset, 1.0, estimator=estimator, taus="octave")
    np.testing.assert_allclose(scaled.avar, scale**2 * base.avar, rtol=1e-9)
    np.testing.assert_allclose(shifted.avar, base.avar, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("estimator", ["overlapping", "clusters"])
def test_white_noise_lies_in_its_confidence_interval_at_the_nominal_rate(estimator: str) -> None:
    """White rate noise of std s: avar(tau) = s^2 dt / tau; the 1-sigma interval must hold it
    in at least the nominal 68.3 % of (seed, tau) cells, and not in far more (too wide)."""
    s, fs, n = 0.3, 50.0, 4096
    hits = []
    for seed in range(150):
        y = white_rate_noise(s / np.sqrt(fs), n, fs, np.random.default_rng(seed))
        r = allan_variance(y, fs, estimator=estimator, taus="octave")
        truth = s**2 / fs / r.tau_s
        hits.append((r.ci_low <= truth) & (truth <= r.ci_high))
    share = np.mean(hits)
    assert 0.66 <= share <= 0.75, share
    per_tau = np.mean(hits, axis=0)
    assert per_tau.min() > 0.55, per_tau


def test_result_units_and_confidence_bounds_are_ordered() -> None:
    y = white_rate_noise(0.01, 20_000, 100.0, np.random.default_rng(0))
    r = overlapping_allan_variance(y, 100.0)
    assert np.all(r.ci_low < r.avar) and np.all(r.avar < r.ci_high)
    np.testing.assert_allclose(r.tau_s, r.m / 100.0)
    np.testing.assert_array_equal(r.n_terms, 20_000 + 1 - 2 * r.m)
    assert np.all(r.adev_ci_low < r.adev)


@pytest.mark.parametrize(
    "generator", [white_rate_noise, random_walk_rate_noise, flicker_rate_noise]
)
def test_computed_edf_matches_the_spread_of_the_estimates(generator) -> None:
    """edf = 2 E[avar]^2 / Var[avar] measured over 300 seeds agrees with the computed edf."""
    n, seeds = 4096, 300
    avars, edfs = [], []
    for seed in range(seeds):
        y = generator(1.0, n, 1.0, np.random.default_rng(seed))
        r = overlapping_allan_variance(y, 1.0, taus=[4, 16, 64, 256, 1024])
        avars.append(r.avar)
        edfs.append(r.edf)
    avars = np.array(avars)
    empirical = 2 * avars.mean(axis=0) ** 2 / avars.var(axis=0, ddof=1)
    computed = np.median(edfs, axis=0)
    # the spread of an empirical edf from 300 seeds is about 10 %; allow 30 %
    np.testing.assert_allclose(computed, empirical, rtol=0.3)
