"""Grades that the record cannot fool: the link's LSB, a stuck output, a constant record,
missing time and a short record (docs/grading.md, "Resolution" and "Missing time")."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest

from analysis.models.noise import white_rate_noise
from analysis.units.conversions import arw_deg_rt_h_to_deg_rt_s
from devices.resolution import FLOAT32_RELATIVE_STEP, STIM300, url_resolution
from station.cli import main
from station.errors import ProfileError
from station.evaluation.grading import grade_run
from station.evaluation.resolution import expected_longest_run, value_census
from station.model.profiles import load_profile, parse_profile
from station.model.quantization import arw_floor_deg_rt_h, quantization_adev_deg_s
from station.storage.csv_records import write_csv_record
from station.storage.runs import open_run

Q = 2.0**-14  # the STIM300's rate LSB, deg/s
FS_HZ = 10.0
MODELS = Path(__file__).resolve().parents[1] / "profiles" / "models"


def profile_text(*, url: str = "sim+serial://CRG20?protocol=stim300&rate=10",
                 duration_s: float = 2400.0, warmup_s: float = 60.0,
                 arw_limits: str = "{ A = 5.0, B = 10.0 }") -> str:
    return f"""name = "RES"
version = "1"
model = "CRG20"

[transport]
url = "{url}"

[test]
sample_rate_hz = 10.0
duration_s = {duration_s}
warmup_s = {warmup_s}
axes = ["x"]

[grading]
grades = ["A", "B"]

[figures.arw_fit]
unit = "deg/sqrt(h)"
limits = {arw_limits}

[figures.bias_instability_fit]
unit = "deg/h"
limits = {{ A = 100.0, B = 200.0 }}

[figures.bias_stability_10s]
unit = "deg/h"
limits = {{ A = 300.0, B = 600.0 }}

[figures.bias]
unit = "deg/h"
limits = {{ A = 300.0, B = 600.0 }}
"""


def write_profile(directory: Path, text: str) -> Path:
    path = directory / "res.toml"
    path.write_text(text, encoding="utf-8")
    return path


def graded_json(argv: list[str], capsys: pytest.CaptureFixture[str]) -> dict:
    assert main(["grade", *argv, "--no-store", "--json"]) == 0
    return json.loads(capsys.readouterr().out)


# --- the physics of the floor ----------------------------------------------------------------


def test_rounding_error_of_a_dithered_rate_word_is_the_floor() -> None:
    """The rounding error of a rate word of LSB q under a noise of a few LSB is white with
    variance q^2/12: the std of its T-second averages is q / sqrt(12 f T) (the floor)."""
    rng = np.random.default_rng(5)
    x = rng.normal(0.0, 3 * Q, 400_000)
    error = np.round(x / Q) * Q - x
    for n in (1, 10, 100):
        averages = error[: len(error) // n * n].reshape(-1, n).mean(axis=1)
        floor = quantization_adev_deg_s(Q, FS_HZ, n / FS_HZ)
        assert np.std(averages) == pytest.approx(floor, rel=0.03)
    # the ARW of that error: 60 q / sqrt(12 f) deg/sqrt(h)
    assert arw_floor_deg_rt_h(Q, FS_HZ) == pytest.approx(3.343e-4, rel=1e-3)


def test_each_protocol_says_its_lsb() -> None:
    assert url_resolution("sim+serial://X?protocol=stim300") == STIM300
    assert STIM300.lsb_deg_s == Q
    for url in ("sim+serial://X?protocol=kvh1750", "serial:///dev/x?protocol=xbus",
                "sim+modbus+tcp://V?map=float32"):
        resolution = url_resolution(url)
        assert resolution is not None and resolution.lsb_relative == FLOAT32_RELATIVE_STEP
    assert url_resolution("sim+can://V?layout=shared").lsb_deg_s == 2.0**-13  # type: ignore[union-attr]
    assert url_resolution("sim+modbus+tcp://V?map=int32").lsb_deg_s == 1e-6  # type: ignore[union-attr]
    assert url_resolution("replay://capture.bin") is None


def test_value_census_counts_runs_across_blocks() -> None:
    x = np.zeros(3_000_000)  # a long record: counted a block at a time
    x[::1000] = Q
    x[1_000_001:1_600_000] = 5 * Q  # one value held across block edges
    c = value_census(x)
    assert c.distinct == 3 and c.step_deg_s == Q
    assert c.longest_run == 599_999 and c.run_value == 5 * Q
    assert c.mode_value == 0.0 and c.mode_share > 0.79
    assert expected_longest_run(1000, 0.5) == pytest.approx(math.log2(500))


# --- the profile's own transport -------------------------------------------------------------


def test_a_profile_whose_transport_cannot_resolve_its_limits_is_refused() -> None:
    tight = "{ A = 1.3e-4 }"
    with pytest.raises(ProfileError, match=r"LSB 6\.1e-05 deg/s at 10 Hz.*floor of "
                                           r"0\.000334 deg/sqrt\(h\)") as caught:
        parse_profile(profile_text(arw_limits=tight), path="res.toml")
    assert "figures.arw_fit.limits.A" in str(caught.value) and "1.3e-04" not in str(caught.value)
    # a float32 word resolves it
    p = parse_profile(profile_text(url="sim+serial://X?protocol=kvh1750&rate=10",
                                   arw_limits=tight))
    assert p.figure("arw_fit").limits["A"] == 1.3e-4


def test_the_shipped_srs2000_profile_loads_with_a_transport_that_resolves_it() -> None:
    p = load_profile("SRS2000")
    resolution = url_resolution(p.transport["url"])
    assert resolution is not None and resolution.lsb_relative == FLOAT32_RELATIVE_STEP


# --- stuck and constant records --------------------------------------------------------------


@pytest.fixture(scope="module")
def flips_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """4 h at 10 Hz of 0 deg/s with 30 one-LSB flips (a STIM300 LSB)."""
    n = int(4 * 3600 * FS_HZ)
    x = np.zeros((n, 1))
    x[np.random.default_rng(1).choice(n, 30, replace=False), 0] = Q
    return write_csv_record(tmp_path_factory.mktemp("flips") / "flips.csv", x, FS_HZ,
                            axis_names=["x"])


def test_zeros_with_30_lsb_flips_get_no_passing_grade(flips_csv: Path, capsys) -> None:
    doc = graded_json([str(flips_csv), "--profile", "SRS2000"], capsys)
    unit = doc["units"][0]
    axis = unit["axes"]["x"]
    assert unit["grade"] == "indeterminate"
    assert any("stuck output" in r and "99.98%" in r for r in unit["review"])
    res = axis["resolution"]
    assert res["stuck"] and res["distinct_values"] == 2 and res["lsb_deg_s"] == Q
    assert res["lsb_source"] == "values"
    for name, fig in axis["figures"].items():  # every graded figure: under its floor
        assert not fig["resolved"], name
        assert "pass" not in fig["verdicts"].values(), name
        assert fig["note"].startswith("not resolved"), name
        assert fig["quantization_floor"] > 0


def test_a_constant_record_is_one_line_without_numpy_warnings(tmp_path: Path, capsys) -> None:
    record = write_csv_record(tmp_path / "zeros.csv", np.zeros((20_000, 1)), FS_HZ,
                              axis_names=["x"])
    profile = write_profile(tmp_path, profile_text())
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a numpy warning would fail the test
        assert main(["grade", str(record), "--profile", str(profile), "--no-store"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "axis x: all 19400 samples are 0 deg/s: a constant output" in err  # (after the warm-up)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["analyze", str(record)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "all 20000 samples are 0 deg/s" in err


def test_a_dithered_quantized_record_is_resolved_and_not_stuck(tmp_path: Path) -> None:
    """A noise of 0.6 LSB a sample moves the word across its steps: no floor, no review."""
    n = 24_000
    sigma = 0.6 * Q
    arw = sigma / math.sqrt(FS_HZ) * 60.0  # deg/sqrt(h)
    rng = np.random.default_rng(2)
    x = 0.002 + white_rate_noise(arw_deg_rt_h_to_deg_rt_s(arw), n, FS_HZ, rng)
    record = write_csv_record(tmp_path / "d.csv", (np.round(x / Q) * Q).reshape(-1, 1), FS_HZ,
                              axis_names=["x"])
    profile = load_profile(write_profile(tmp_path, profile_text()))
    unit = grade_run(open_run(record), profile).units[0]
    axis = unit.axis("x")
    assert axis.resolution is not None and axis.resolution.lsb_deg_s == Q
    assert not axis.resolution.stuck and not unit.review
    assert all(f.resolved for f in axis.graded_figures)
    assert unit.grade == "A"


# --- missing time and short records ----------------------------------------------------------


def _gapped_csv(path: Path, keep: float) -> Path:
    """A 2400 s record at 10 Hz (white noise) whose middle ``1 - keep`` has no sample."""
    n = 24_000
    rng = np.random.default_rng(4)
    x = 0.002 + white_rate_noise(arw_deg_rt_h_to_deg_rt_s(0.5), n, FS_HZ, rng)
    t = np.arange(n) / FS_HZ
    cut = (t > 1200 * keep) & (t < 2400 - 1200 * keep)
    kept = zip(t[~cut].tolist(), x[~cut].tolist(), strict=True)
    lines = ["time,x"] + [f"{ti:.1f},{xi!r}" for ti, xi in kept]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_half_the_time_missing_is_reviewed(tmp_path: Path, capsys) -> None:
    profile = write_profile(tmp_path, profile_text())
    doc = graded_json([str(_gapped_csv(tmp_path / "half.csv", 0.5)), "--profile",
                       str(profile)], capsys)
    unit = doc["units"][0]
    cov = unit["coverage"]
    assert cov["missing_share"] == pytest.approx(0.5, abs=0.001) and not cov["short"]
    assert any(r.startswith("record: 50.0% of the run's 2400 s has no sample")
               for r in unit["review"])
    assert unit["grade"] == "A"  # half the test: reviewed, not refused


def test_more_than_half_missing_gets_no_passing_grade(tmp_path: Path, capsys) -> None:
    """57 % of the time missing (the issue's units were graded A and B)."""
    profile = write_profile(tmp_path, profile_text())
    doc = graded_json([str(_gapped_csv(tmp_path / "most.csv", 0.43)), "--profile",
                       str(profile)], capsys)
    unit = doc["units"][0]
    assert unit["grade"] == "indeterminate"
    assert unit["axes"]["x"]["could_reach"] == "A"
    assert unit["coverage"]["missing_share"] == pytest.approx(0.57, abs=0.001)
    assert unit["coverage"]["insufficient"] and unit["coverage"]["covered_share"] < 0.5
    assert any("under the 50% a passing grade needs" in r for r in unit["review"])


def test_a_csv_half_the_profiles_length_is_short(tmp_path: Path, capsys) -> None:
    profile = write_profile(tmp_path, profile_text(duration_s=4800.0))
    doc = graded_json([str(_gapped_csv(tmp_path / "full.csv", 1.0)), "--profile",
                       str(profile)], capsys)
    unit = doc["units"][0]
    assert unit["coverage"]["short"] and unit["coverage"]["span_source"] == "record"
    assert "record: record 2400 s is shorter than the profile's test (4800 s)" in unit["review"]


def test_a_run_recorded_for_the_profiles_duration_is_not_short(tmp_path: Path) -> None:
    """A simulated STIM300 unit recorded at warp for exactly the profile's 5 minutes: its
    length is the recorder's span, whatever samples the link lost at its ends."""
    profile_path = write_profile(tmp_path, profile_text(duration_s=300.0, warmup_s=30.0))
    url = (f"sim+serial://CRG20?model={MODELS / 'CRG20.toml'}&protocol=stim300&rate=10"
           "&warp=250&seed=3")
    assert main(["record", "--profile", str(profile_path), "--unit", url, "--duration", "5m",
                 "--out", str(tmp_path / "runs"), "--quiet"]) == 0
    run_file = next((tmp_path / "runs").glob("*.h5"))
    with h5py.File(run_file) as f:
        assert f["units/unit1"].attrs["lsb_deg_s"] == Q
    run = open_run(run_file)
    assert run.recorded_span_s == 300.0
    unit = grade_run(run, load_profile(profile_path)).units[0]
    assert unit.coverage is not None and unit.coverage.span_source == "recorder"
    assert unit.coverage.span_s == 300.0 and not unit.coverage.short
    assert not any("shorter" in r for r in unit.review) and not any("shorter" in n
                                                                   for n in unit.notes)
    resolution = unit.axis("x").resolution
    assert resolution is not None and resolution.link_lsb_deg_s == Q
