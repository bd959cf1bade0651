"""Partial clusters: records with many short gaps keep averages missing a small share."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from analysis.allan.gaps import gap_allan_variance, gap_summary
from analysis.allan.partial_clusters import (
    MAX_MISSING_SHARE,
    partial_allan_variance,
    partial_means,
    white_level,
)
from analysis.allan.variance import allan_variance
from analysis.errors import TooFewSamplesError
from analysis.figures.spec import bias_stability
from analysis.models.simulation import polled_loss
from station.evaluation.grading import grade_run
from station.model.profiles import load_profile
from station.storage.csv_records import write_csv_record
from station.storage.runs import open_run
from tests.test_grading import FS_HZ, make_rate, profile_text, write_profile


def _record(n: int, seed: int) -> np.ndarray:
    """White rate plus a slow random walk, deg/s."""
    rng = np.random.default_rng(seed)
    return 0.01 * rng.standard_normal(n) + 2e-5 * np.cumsum(rng.standard_normal(n))


@pytest.mark.parametrize("estimator", ["overlapping", "clusters"])
def test_without_a_missing_sample_equals_the_unbroken_estimator(estimator: str) -> None:
    x = _record(6000, 1)
    got = partial_allan_variance(x, 10.0, estimator=estimator, taus="octave")
    ref = allan_variance(x, 10.0, estimator=estimator, taus="octave")
    np.testing.assert_allclose(got.avar, ref.avar, rtol=1e-10)
    np.testing.assert_allclose(got.edf, ref.edf, rtol=1e-10)


def test_polled_loss_makes_short_runs_of_the_share_asked() -> None:
    mask = polled_loss(20_000, missing_share=0.068, rng=np.random.default_rng(2))
    summary = gap_summary(mask)
    assert summary.share == pytest.approx(0.068, abs=2e-4)
    assert summary.lengths.min() >= 1 and summary.lengths.max() <= 3
    assert summary.count > 0.068 * 20_000 / 3


def test_short_gaps_keep_every_tau_near_the_unbroken_curve_with_wider_intervals() -> None:
    """6.8 % lost in runs of 1-3 samples: the strict rule loses the long taus, partial
    clusters keep them, each inside its interval around the unbroken value."""
    n, fs = 12_000, 10.0
    x = _record(n, 3)
    gapped = np.where(polled_loss(n, missing_share=0.068, rng=np.random.default_rng(4)), x,
                      np.nan)
    ref = allan_variance(x, fs, taus="octave")
    got = partial_allan_variance(gapped, fs, taus="octave")
    strict = gap_allan_variance(gapped, fs, taus="octave")
    assert strict.tau_s[-1] < ref.tau_s[-1] / 8
    np.testing.assert_array_equal(got.tau_s, ref.tau_s)
    assert (got.ci_low <= ref.avar).all() and (ref.avar <= got.ci_high).all()
    assert (got.edf <= ref.edf * 1.000001).all() and (got.edf < ref.edf).any()
    with pytest.raises(TooFewSamplesError):  # no cluster of 0.1 s misses a sample: none kept
        partial_allan_variance(np.where(np.arange(n) % 2 == 0, x, np.nan), fs, taus=[0.1])


def test_an_average_missing_more_than_the_share_is_left_out() -> None:
    x = np.arange(40, dtype=float)
    x[3] = np.nan  # 1 of 10: kept
    x[12:14] = np.nan  # 2 of 10: over the 10 % share
    means = partial_means(x, 10)
    assert MAX_MISSING_SHARE == pytest.approx(0.1)
    assert means.n_dropped == 1
    np.testing.assert_array_equal(means.present, [9, 10, 10])
    assert means.means[0] == pytest.approx(np.mean([0, 1, 2, 4, 5, 6, 7, 8, 9]))
    assert means.missing_share == pytest.approx(1 / 30)


def test_bias_stability_of_a_gapped_record_has_a_value_and_a_reduced_edf() -> None:
    n, fs = 12_000, 10.0
    x = _record(n, 5)
    gapped = np.where(polled_loss(n, missing_share=0.068, rng=np.random.default_rng(6)), x,
                      np.nan)
    ref = bias_stability(x, fs, 100.0)
    got = bias_stability(gapped, fs, 100.0,
                         white_level=white_level(partial_allan_variance(gapped, fs)))
    assert bias_stability(gapped, fs, 100.0, max_missing_share=0.0).value_deg_h is None
    assert got.value_deg_h is not None and ref.value_deg_h is not None
    assert got.edf is not None and ref.edf is not None and got.edf < ref.edf
    assert got.ci_low_deg_h is not None and got.ci_high_deg_h is not None
    assert got.ci_low_deg_h <= ref.value_deg_h <= got.ci_high_deg_h


def test_grading_a_record_with_short_gaps_gives_a_verdict(tmp_path: Path) -> None:
    n = 12_000
    rate = make_rate(n, 7)
    index = np.flatnonzero(polled_loss(n, missing_share=0.068, rng=np.random.default_rng(8)))
    path = write_csv_record(tmp_path / "polled.csv", rate[index], FS_HZ, axis_names=["x"],
                            sample_index=index)
    figures = """
[figures.bias_stability_100s]
unit = "deg/h"
limits = { A = 5.0, B = 20.0 }
"""
    text = profile_text(figures=figures, duration_s=1200.0)  # the record's 20 min
    profile = load_profile(write_profile(tmp_path, text))
    axis = grade_run(open_run(path), profile).units[0].axis("x")
    figure = next(f for f in axis.figures if f.name == "bias_stability_100s")
    assert figure.value is not None and "missing" in figure.note
    assert axis.grade == "A"
