"""Isolated spikes: found where they were put, nowhere in clean records of any noise type,
removed by the stated rule, reported in every format, and found in the real MTi-G record."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from pypdf import PdfReader

from analysis.allan.outliers import (
    MAX_REMOVED_SHARE,
    _neighbour_residuals_long,
    detect_spikes,
    neighbour_residuals,
    replace_spikes,
    spike_threshold,
)
from analysis.allan.variance import allan_variance
from analysis.models.simulation import simulate
from analysis.models.terms import (
    AngleRandomWalk,
    BiasInstability,
    NoiseModel,
    Quantization,
    RateRandomWalk,
)
from analysis.units.conversions import S_PER_H
from station.cli import main
from station.evaluation.analyze import analyze_record
from station.evaluation.grading import grade_run
from station.model.profiles import load_profile
from station.model.records import RateRecord
from station.model.runs import RunInfo, UnitRun
from station.output.report import write_report
from station.storage.csv_records import write_csv_record
from station.storage.runs import read_record
from tests.test_grading import profile_text, write_profile

FS_HZ = 100.0
MTIG = (
    Path(__file__).resolve().parents[2]
    / "shared"
    / "real-data"
    / "mtig_cont_imu1_gyro_x_100hz.csv.gz"
)


def _clean(n: int, seed: int) -> np.ndarray:
    """White rate noise (0.5 deg/sqrt(h)) plus bias instability (5 deg/h), deg/s."""
    model = NoiseModel(terms=(AngleRandomWalk(N_deg_rt_h=0.5), BiasInstability(B_deg_h=5.0)))
    return simulate(model, n / FS_HZ, FS_HZ, seed=seed, flicker_floor_hz=1e-4).rate_deg_s[:, 0]


def _with_spikes(x: np.ndarray, seed: int, count: int = 20) -> tuple[np.ndarray, dict[int, int]]:
    """Spikes of 20-40 sigma, random signs, 1 or 2 samples long, at least 50 samples apart."""
    rng = np.random.default_rng(seed)
    sigma = float(np.std(x))
    where = np.sort(rng.choice(np.arange(100, len(x) - 100, 50), count, replace=False))
    y = x.copy()
    lengths = {}
    for k in where:
        n = int(rng.integers(1, 3))
        y[k:k + n] += rng.choice([-1, 1]) * rng.uniform(20, 40) * sigma
        lengths[int(k)] = n
    return y, lengths


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_spikes_are_found_where_they_were_put(seed: int) -> None:
    x = _clean(50_000, seed)
    y, lengths = _with_spikes(x, seed)
    d = detect_spikes(y)
    assert {sp.index: sp.n_samples for sp in d.spikes} == lengths
    assert d.removable and d.count == sum(lengths.values())
    for sp in d.spikes:  # the size is the spike's, to within the noise
        k = sp.index
        true = float(np.max(np.abs(y[k:k + sp.n_samples] - x[k:k + sp.n_samples])))
        assert abs(abs(sp.size) - true) < 4 * d.scale


def test_removed_spikes_give_back_the_clean_allan_curve() -> None:
    x = _clean(50_000, 7)
    y, _ = _with_spikes(x, 7)
    record = RateRecord(y[:, None], FS_HZ, ("x",), "spiky")
    (axis,) = analyze_record(record)
    clean = allan_variance(x, FS_HZ, taus=axis.allan.tau_s)  # on analyze's grid
    assert axis.outliers.removed and axis.outliers.count == 20
    half_width = (clean.adev_ci_high - clean.adev_ci_low) / 2  # the clean record's 1-sigma
    assert np.max(np.abs(axis.allan.adev - clean.adev) / half_width) < 0.25  # measured 0.11
    kept = axis.allan_alternative
    assert axis.alternative_label == "spikes kept" and kept is not None
    assert np.max(np.abs(kept.adev - clean.adev) / half_width) > 10  # what the spikes did: 64
    # the mean of the clean record to a small part of its standard error (about 1.3 deg/h)
    assert axis.figures.bias_deg_h == pytest.approx(np.mean(x) * S_PER_H, abs=0.2)
    (as_kept,) = analyze_record(record, outliers="keep")
    assert not as_kept.outliers.removed and as_kept.outliers.count == 20
    np.testing.assert_allclose(as_kept.allan.adev, kept.adev, rtol=1e-12)


def _noise(kind: str, n: int, seed: int) -> np.ndarray:
    terms = {"white": (AngleRandomWalk(N_deg_rt_h=0.5),),
             "flicker": (BiasInstability(B_deg_h=5.0),),
             "rrw": (RateRandomWalk(K_deg_h_1_5=50.0),),
             "quantization": (Quantization(Q_urad=50.0),)}
    if kind == "lsb":  # white noise of 0.4 LSB on a 0.05 deg/s output quantum
        rng = np.random.default_rng(seed)
        return 0.05 * np.round(0.4 * rng.standard_normal(n) + 0.3)
    return simulate(NoiseModel(terms=terms[kind]), n / FS_HZ, FS_HZ, seed=seed).rate_deg_s[:, 0]


@pytest.mark.parametrize("kind", ["white", "flicker", "rrw", "quantization", "lsb"])
def test_clean_records_of_every_noise_type_have_no_spikes(kind: str) -> None:
    """Negative controls, 4 seeds each (designed false-alarm rate 1 % per record; measured
    over 200 records per type by benchmarks/bench_outliers.py)."""
    for seed in range(4):
        d = detect_spikes(_noise(kind, 20_000, seed))
        assert d.count == 0, (kind, seed, d.spikes[:3])


def test_threshold_and_rule() -> None:
    assert spike_threshold(1_000_000) == pytest.approx(5.730, abs=1e-3)
    assert spike_threshold(1_000) < spike_threshold(1_000_000)
    x = _clean(20_000, 4)
    burst = x.copy()
    burst[5000:5006] += 40 * np.std(x)  # six samples: a burst, not an isolated spike
    d = detect_spikes(burst)
    assert d.longest_run == 6 and not d.removable and "bursts" in d.rule_text()
    many = x.copy()
    many[::400] += 30 * np.std(x)  # 0.25 % of the samples
    d = detect_spikes(many)
    assert d.share > MAX_REMOVED_SHARE and not d.removable and "heavy-tailed" in d.rule_text()
    (axis,) = analyze_record(RateRecord(many[:, None], FS_HZ, ("x",)))
    assert not axis.outliers.removed
    (forced,) = analyze_record(RateRecord(many[:, None], FS_HZ, ("x",)), outliers="remove")
    assert forced.outliers.removed and "--outliers remove" in forced.outliers.rule


def test_replacement_is_the_line_between_the_neighbours() -> None:
    x = np.array([0.0, 1.0, 50.0, 3.0, 4.0, -60.0])
    flags = np.array([0, 0, 1, 0, 0, 1], dtype=bool)
    np.testing.assert_allclose(replace_spikes(x, flags), [0, 1, 2, 3, 4, 4])
    positions = np.array([0, 1, 2, 4, 5, 6])  # a gap after the spike: interpolate in time
    np.testing.assert_allclose(replace_spikes(x, flags, positions)[2], 1 + (3 - 1) / 3)


def test_every_report_says_what_was_done_with_the_spikes(tmp_path: Path) -> None:
    x = _clean(12_000, 11)
    y, _ = _with_spikes(x, 11, count=5)
    path = write_csv_record(tmp_path / "spiky.csv", y, FS_HZ, axis_names=["x"])
    profile = load_profile(write_profile(tmp_path, profile_text(warmup_s=0.0)))
    record = read_record(path)
    graded = grade_run(RunInfo(str(path), (UnitRun("u1", "TG", "SN-5", record),)), profile)
    doc = json.loads(write_report(graded, "json", tmp_path).read_text())
    assert doc["units"][0]["axes"]["x"]["outliers"]["count"] == 5
    assert doc["units"][0]["axes"]["x"]["outliers"]["removed"] is True
    html = write_report(graded, "html", tmp_path).read_text()
    assert "spikes: x 5 removed" in html
    with write_report(graded, "csv", tmp_path).open(newline="") as fh:
        row = next(csv.DictReader(fh))
    assert (row["spikes"], row["spikes_removed"]) == ("5", "true")
    pages = PdfReader(write_report(graded, "pdf", tmp_path)).pages
    assert "x spikes kept" in pages[0].extract_text()  # the second curve on the plot
    assert "spikes: x 5 removed" in pages[-1].extract_text()  # the note on the test record


def test_analyze_json_and_table_report_spikes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    y, _ = _with_spikes(_clean(20_000, 5), 5, count=3)
    path = write_csv_record(tmp_path / "s.csv", y, FS_HZ, axis_names=["x"])
    assert main(["analyze", str(path), "--json"]) == 0
    axis = json.loads(capsys.readouterr().out)["axes"][0]
    assert axis["outliers"]["count"] == 3 and axis["outliers"]["removed"] is True
    assert [s["time_s"] for s in axis["outliers"]["spikes"]] == sorted(
        s["time_s"] for s in axis["outliers"]["spikes"]
    )
    assert axis["gaps"] == {"count": 0, "missing_s": 0.0, "share": 0.0}
    assert axis["figures"]["earth_rate_removed_deg_h"] is None
    assert main(["analyze", str(path), "--outliers", "keep"]) == 0
    out = capsys.readouterr().out
    assert "3 kept" in out and "kept in the analysis" in out


@pytest.mark.skipif(not MTIG.exists(), reason="real data not found at ../shared/real-data")
def test_the_mtig_record_holds_isolated_spikes() -> None:
    """Xsens MTi-G, 1.4 h at 100 Hz, published as containing outliers."""
    record = read_record(MTIG, sample_rate_hz=100.0, units="rad/s")
    (axis,) = analyze_record(record)
    o = axis.outliers
    assert o.removed and o.detection is not None
    assert 250 <= o.count <= 320 and o.detection.longest_run <= 3  # 287 spikes, 366 samples
    assert max(abs(sp.size) for sp in o.detection.spikes) * S_PER_H > 5e4  # deg/h; the noise: ~500
    kept = axis.allan_alternative
    assert kept is not None
    # the taus of at least nine clusters: past them the two curves differ by the noise of a
    # few clusters (analyze's grid reaches two clusters)
    resolved = axis.allan.n_clusters >= 9
    ratio = axis.allan.adev[resolved] / kept.adev[resolved]
    assert np.all((ratio > 0.9) & (ratio < 1.0))  # the spikes raised the whole curve ...
    assert np.all(ratio[axis.allan.tau_s[resolved] <= 10.0] < 0.965)  # ... by 4-6 % up to 10 s


@pytest.mark.parametrize("half_window", [1, 3, 8])
def test_neighbour_residuals_are_the_padded_running_median(half_window: int) -> None:
    """Each sample minus the median of its 2w neighbours, the record mirrored at its ends
    (np.pad's "symmetric"), bit for bit, at the ends and inside, in memory and block-wise."""
    w = half_window
    x = np.random.default_rng(7).standard_normal(5000).round(2)  # ties, as quantized data has
    windows = np.lib.stride_tricks.sliding_window_view(np.pad(x, w, mode="symmetric"), 2 * w + 1)
    expected = x - np.median(np.concatenate((windows[:, :w], windows[:, w + 1:]), axis=1), axis=1)
    assert np.array_equal(neighbour_residuals(x, half_window=w), expected)
    picks = np.array([0, 1, w, 2500, len(x) - w - 1, len(x) - 1])
    assert np.array_equal(neighbour_residuals(x, picks, w), expected[picks])
    assert np.array_equal(_neighbour_residuals_long(x, picks, w), expected[picks])
