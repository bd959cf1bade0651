"""Gap-aware Allan variance: equal to the gap-free estimators without gaps, exact against a
brute-force sum with them, and the same curve as the unbroken record where concatenating
the stretches is not."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analysis.allan import kernels
from analysis.allan.gaps import gap_summary
from analysis.allan.partial_clusters import partial_allan_variance
from analysis.allan.variance import allan_variance
from analysis.errors import NonFiniteSamplesError, TooFewSamplesError


def _brute_overlapping(y: np.ndarray, m: int, fs: float) -> tuple[float, int]:
    """Every second difference of the grid whose 2m samples are all present, one by one."""
    valid = ~np.isnan(y)
    present = y[valid] - y[valid].mean()
    theta = np.concatenate([[0.0], np.cumsum(present) / fs])
    count = np.concatenate([[0], np.cumsum(valid)])
    total, terms = 0.0, 0
    for n in range(len(y) - 2 * m + 1):
        if count[n + 2 * m] - count[n] == 2 * m:
            i = count[n]
            d = theta[i + 2 * m] - 2 * theta[i + m] + theta[i]
            total, terms = total + d * d, terms + 1
    return total / (2 * (m / fs) ** 2 * terms), terms


def _brute_clusters(y: np.ndarray, m: int) -> tuple[float, int, int]:
    """Cluster means on the time grid; a cluster missing a sample is dropped with its
    differences."""
    means = np.array([np.nan if np.isnan(c).any() else c.mean()
                      for c in (y[k * m:(k + 1) * m] for k in range(len(y) // m))])
    d = np.diff(means)
    ok = ~np.isnan(d)
    return float(np.sum(d[ok] ** 2) / (2 * ok.sum())), int(ok.sum()), int((~np.isnan(means)).sum())


def _gappy(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    y = rng.standard_normal(n) + np.linspace(0.0, 3.0, n)
    for a, b in ((100, 107), (2000, 2001), (3100, 3400), (n - 5, n - 3)):
        y[a:b] = np.nan
    return y


@pytest.mark.parametrize("estimator", ["overlapping", "clusters"])
def test_without_gaps_equals_the_gap_free_estimator(estimator: str) -> None:
    rng = np.random.default_rng(4)
    x = rng.standard_normal((20011, 2)) + np.cumsum(rng.standard_normal((20011, 2)), axis=0) * 0.01
    plain = allan_variance(x, 10.0, estimator=estimator, taus="octave")
    gapped = allan_variance(x, 10.0, estimator=estimator, taus="octave", missing="gap")
    np.testing.assert_allclose(gapped.avar, plain.avar, rtol=1e-12)
    np.testing.assert_allclose(gapped.edf, plain.edf, rtol=1e-9)
    np.testing.assert_array_equal(gapped.n_terms, plain.n_terms)
    np.testing.assert_array_equal(gapped.n_clusters, plain.n_clusters)


def test_overlapping_with_gaps_sums_exactly_the_complete_differences() -> None:
    y = _gappy(4001, 1)
    fs = 2.0
    result = allan_variance(y, fs, taus=np.array([1, 3, 40, 300]) / fs, missing="gap")
    for i, m in enumerate(result.m):
        value, terms = _brute_overlapping(y, int(m), fs)
        assert result.n_terms[i] == terms
        assert result.avar[i] == pytest.approx(value, rel=1e-12)


def test_clusters_with_gaps_sit_on_the_time_grid_and_skip_incomplete_ones() -> None:
    y = _gappy(5003, 3)
    result = allan_variance(y, 2.0, estimator="clusters", taus="all", missing="gap")
    for i in (0, 3, 50, 400, len(result.m) - 1):
        value, terms, complete = _brute_clusters(y, int(result.m[i]))
        assert (result.n_terms[i], result.n_clusters[i]) == (terms, complete)
        assert result.avar[i] == pytest.approx(value, rel=1e-12)


def test_compiled_and_numpy_stretch_kernels_agree() -> None:
    if not kernels.have_compiled():
        pytest.skip("numba is not installed: only the numpy kernel exists")
    rng = np.random.default_rng(2)
    theta = np.cumsum(rng.standard_normal((30001, 2)), axis=0)
    starts, stops = np.array([0, 17, 18, 9000]), np.array([17, 18, 9000, 30000])
    m = np.array([1, 2, 8, 333, 4000])
    fast = kernels.overlapping_stretch_sums(theta, m, starts, stops, backend="numba")
    slow = kernels.overlapping_stretch_sums(theta, m, starts, stops, backend="numpy")
    np.testing.assert_allclose(fast, slow, rtol=1e-12)


def test_gaps_lower_the_edf_and_widen_the_interval() -> None:
    rng = np.random.default_rng(5)
    x = rng.standard_normal(40000)
    y = x.copy()
    y[10000:14000] = np.nan
    y[25000:25010] = np.nan
    full = allan_variance(x, 1.0, missing="gap")
    gapped = allan_variance(y, 1.0, missing="gap", taus=full.tau_s[full.m <= 7000])
    k = len(gapped.m)
    assert np.all(gapped.edf <= full.edf[:k] * (1 + 1e-9))
    assert np.all(gapped.edf[-5:] < full.edf[:k][-5:])


def test_refuses_what_it_cannot_estimate() -> None:
    y = _gappy(4001, 1)
    with pytest.raises(TooFewSamplesError, match="without a gap"):
        allan_variance(y, 1.0, taus=[1500.0], missing="gap")
    both = np.column_stack([y, y])
    both[50, 1] = np.nan
    with pytest.raises(ValueError, match="different samples"):
        allan_variance(both, 1.0, missing="gap")
    y[7] = np.inf
    with pytest.raises(NonFiniteSamplesError, match="infinite"):
        allan_variance(y, 1.0, missing="gap")
    with pytest.raises(NonFiniteSamplesError):
        allan_variance(_gappy(4001, 1), 1.0)  # without missing="gap" a NaN is still refused


def test_gap_summary_counts_gaps_and_their_share() -> None:
    valid = np.ones(1000, dtype=bool)
    valid[[0, 1, 500, 501, 502, 999]] = False
    s = gap_summary(valid)
    assert (s.count, s.missing_samples, s.span_samples) == (3, 6, 1000)
    np.testing.assert_array_equal(s.starts, [0, 500, 999])
    np.testing.assert_array_equal(s.lengths, [2, 3, 1])
    assert s.share == pytest.approx(0.006)


#: The 8 h record's outages (s from the start, 1 Hz): one of 1 h and four short ones.
OUTAGES_S = ((3600, 7200), (1440, 1460), (9000, 9060), (10440, 10445), (27360, 27480))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_eight_hours_with_outages_give_the_unbroken_curve_where_concatenation_does_not(
    seed: int,
) -> None:
    """White rate noise, a rate ramp and a sinusoid, 8 h at 1 Hz; 1 h and four short outages.

    The unbroken record's Allan deviation lies inside the gapped record's 1-sigma interval
    at every tau (and the gapped value inside the unbroken one's); the concatenated
    stretches put a rate step at each seam and leave both intervals at many taus.
    """
    fs, n = 1.0, 8 * 3600
    t = np.arange(n) / fs
    rng = np.random.default_rng(seed)
    x = 0.01 * rng.standard_normal(n) + 5e-6 * t + 0.01 * np.sin(2 * np.pi * t / 1300.0)  # deg/s
    y = x.copy()
    for a, b in OUTAGES_S:
        y[a:b] = np.nan
    gapped = allan_variance(y, fs, missing="gap")
    unbroken = allan_variance(x, fs, taus=gapped.tau_s)
    assert gapped.tau_s[-1] == pytest.approx(3200.0)  # true time: 8 h / 9 clusters
    assert np.all((unbroken.avar >= gapped.ci_low) & (unbroken.avar <= gapped.ci_high))
    assert np.all((gapped.avar >= unbroken.ci_low) & (gapped.avar <= unbroken.ci_high))
    present = y[~np.isnan(y)]
    naive = allan_variance(present, fs, taus=gapped.tau_s[gapped.m <= len(present) // 2])
    k = len(naive.m)
    outside = (naive.avar < unbroken.ci_low[:k]) | (naive.avar > unbroken.ci_high[:k])
    assert outside.sum() >= 10
    assert np.max(naive.adev / unbroken.adev[:k]) > 1.2


def test_analyze_reads_the_gaps_of_a_csv_time_column(
    tmp_path, capsys: pytest.CaptureFixture[str]
) -> None:
    from station.cli import main
    from station.storage.csv_records import write_csv_record

    n = 8 * 3600
    keep = np.ones(n, dtype=bool)
    for a, b in OUTAGES_S:
        keep[a:b] = False
    rng = np.random.default_rng(9)
    rate = 0.01 * rng.standard_normal(n) + 5e-6 * np.arange(n)
    index = np.flatnonzero(keep)
    path = write_csv_record(
        tmp_path / "outages.csv", rate[keep], 1.0, axis_names=["x"], sample_index=index
    )
    assert main(["analyze", str(path), "--json"]) == 0
    axis = json.loads(capsys.readouterr().out)["axes"][0]
    missing = sum(b - a for a, b in OUTAGES_S)
    assert axis["gaps"] == {
        "count": 5,
        "missing_s": pytest.approx(missing),
        "share": pytest.approx(missing / n),
    }
    assert axis["tau_s"][-1] == pytest.approx(3200.0)
    # the station keeps clusters missing at most a tenth of their samples (partial clusters)
    expected = partial_allan_variance(np.where(keep, rate, np.nan), 1.0)
    np.testing.assert_allclose(axis["adev"], expected.adev, rtol=1e-9)
    assert main(["analyze", str(path)]) == 0
    assert "5 (3805 s, 13.21% of the time)" in capsys.readouterr().out
