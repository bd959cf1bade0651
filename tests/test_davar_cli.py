"""``station davar FILE`` as a user runs it: JSON interface, summary, heat map, errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib import image

from analysis.davar.estimators import dynamic_allan_variance
from station.cli import main
from station.storage.csv_records import write_csv_record

FS = 10.0
N = 30_000  # 3000 s
T_WARM = 150.0  # s


@pytest.fixture(scope="module")
def rate() -> np.ndarray:
    """Axis x warms up (bias and noise decay with T_WARM), axis y is stationary; deg/s."""
    rng = np.random.default_rng(31)
    t = np.arange(N) / FS
    decay = np.exp(-t / T_WARM)
    x = rng.standard_normal(N) * (1.0 + 2.0 * decay) + 3.0 * decay
    y = rng.standard_normal(N)
    return np.column_stack([x, y])


@pytest.fixture(scope="module")
def record_csv(tmp_path_factory: pytest.TempPathFactory, rate: np.ndarray) -> Path:
    return write_csv_record(tmp_path_factory.mktemp("davar") / "warm.csv", rate, FS,
                            axis_names=["x", "y"])


def test_json_interface(record_csv: Path, rate: np.ndarray) -> None:
    proc = subprocess.run([sys.executable, "-m", "station.cli", "davar", str(record_csv),
                           "--rate", "10", "--window-s", "100", "--json"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert list(out) == ["axes"]
    x, y = out["axes"]
    assert set(x) == {"name", "quantity", "t_s", "tau_s", "adev", "adev_deg_s", "adev_deg_h",
                      "warmup_end_s", "stationary"}
    assert x["quantity"] == "rate"
    assert x["adev_deg_s"] == x["adev"]  # the old key stays, in deg/s
    np.testing.assert_allclose(np.array(x["adev_deg_h"]), 3600 * np.array(x["adev"]), rtol=1e-12)
    assert (x["name"], y["name"]) == ("x", "y")
    expected = dynamic_allan_variance(rate, FS, window_s=100.0)
    assert len(x["t_s"]) == 291  # (3000 - 100) / 10 + 1 windows at the default step Nw/10
    np.testing.assert_allclose(x["t_s"], expected.t_s)
    np.testing.assert_allclose(x["tau_s"], expected.tau_s)
    np.testing.assert_allclose(np.array(x["adev"]), expected.axis(0).adev, rtol=1e-12)
    np.testing.assert_allclose(np.array(y["adev"]), expected.axis(1).adev, rtol=1e-12)
    assert x["stationary"] is False
    assert 1.5 * T_WARM <= x["warmup_end_s"] <= 5 * T_WARM
    assert y["stationary"] is True and y["warmup_end_s"] == 0.0


def test_summary_and_heat_map(
    record_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    png = tmp_path / "maps" / "davar.png"
    assert main(["davar", str(record_csv), "--window-s", "100", "--step-s", "20",
                 "--png", str(png)]) == 0
    text = capsys.readouterr().out
    assert "30000 samples at 10 Hz" in text
    assert "window 100 s (1000 samples), step 20 s, 146 windows" in text
    assert "axis x:" in text and "warm-up ends at" in text
    assert "axis y:" in text and "no warm-up; stationary" in text
    assert f"heat map: {png}" in text
    pixels = image.imread(png)
    assert pixels.shape[0] > 400 and pixels.shape[1] > 800  # two stacked panels
    assert pixels[..., :3].std() > 0.1  # a coloured map, not a blank canvas


def test_units_and_axis_selection(
    record_csv: Path, rate: np.ndarray, capsys: pytest.CaptureFixture
) -> None:
    assert main(["davar", str(record_csv), "--window-s", "300", "--axis", "y",
                 "--units", "deg/h", "--json"]) == 0
    (axis,) = json.loads(capsys.readouterr().out)["axes"]
    expected = dynamic_allan_variance(rate[:, 1] / 3600.0, FS, window_s=300.0)
    np.testing.assert_allclose(np.array(axis["adev"]), expected.adev, rtol=1e-12)


def test_errors_are_one_line_messages(record_csv: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["davar", str(record_csv), "--window-s", "5000"]) == 2
    assert "longer than the record" in capsys.readouterr().err
    assert main(["davar", str(record_csv), "--window-s", "100", "--step-s", "0.01"]) == 2
    assert "less than one sample" in capsys.readouterr().err
    assert main(["davar", str(record_csv.with_name("missing.csv")), "--window-s", "100"]) == 2
    assert "no such file" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["davar", str(record_csv)])  # --window-s is required


def test_a_profile_warm_up_is_left_out_and_said(
    record_csv: Path, capsys: pytest.CaptureFixture
) -> None:
    """davar's --profile promised the profile's warm-up is discarded (CRG20: 120 s)."""
    assert (
        main(["davar", str(record_csv), "--window-s", "100", "--profile", "CRG20", "--json"]) == 0
    )
    captured = capsys.readouterr()
    assert "the first 120 s are left out (warm-up from profile CRG20)" in captured.err
    x = json.loads(captured.out)["axes"][0]
    assert x["t_s"][0] == pytest.approx(
        120 + 50
    )  # the first window's centre, from the record start
    assert x["warmup_end_s"] >= 120


def test_a_record_with_gaps_leaves_out_the_windows_that_hold_one(
    tmp_path: Path, rate: np.ndarray, capsys: pytest.CaptureFixture
) -> None:
    """A CSV whose time column jumps over 100 s: the windows across the gap are null in the
    JSON (those missing at most a tenth keep partial clusters), the whole ones equal the
    DAVAR of the unbroken record at their true times, and the
    summary says how many windows were left out."""
    index = np.r_[0:12_000, 13_000:N]  # 1000 samples (100 s) lost
    path = write_csv_record(
        tmp_path / "gap.csv", rate[index], FS, axis_names=["x", "y"], sample_index=index
    )
    assert main(["davar", str(path), "--window-s", "300", "--json"]) == 0
    axis = json.loads(capsys.readouterr().out)["axes"][1]
    ref = dynamic_allan_variance(rate[:, 1], FS, window_s=300.0)
    np.testing.assert_allclose(axis["t_s"], ref.t_s)
    broken = [any(v is None for v in row) for row in axis["adev"]]
    starts = np.asarray(axis["t_s"]) * FS - 1500
    lost = np.clip(np.minimum(starts + 3000, 13_000) - np.maximum(starts, 12_000), 0, None)
    assert broken == list(lost > 300)  # over a tenth of the window missing
    whole = [row for row, n in zip(axis["adev"], lost, strict=True) if n == 0]
    np.testing.assert_allclose(whole, ref.adev[lost == 0], rtol=1e-9)
    assert main(["davar", str(path), "--window-s", "300"]) == 0
    assert "windows that miss more are left out" in capsys.readouterr().err
