"""Accelerometer axes in the plots: the Allan deviation drawn in m/s^2 (or mg, ug), never
as deg/h; ``station analyze --png`` writes the accelerometers' plot beside the rates';
``station davar --axis accel_x`` in m/s^2; ``station reconcile`` on an accelerometer axis
refuses in one line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from analysis.units.conversions import STANDARD_GRAVITY_M_S2
from station.cli import main
from station.evaluation.analyze import analyze_rates, analyze_record
from station.output.plots import allan_figure, wavelet_figure
from station.storage.csv_records import read_csv_record, write_csv_record

RATE_HZ = 10.0
VRW_M_S2_PER_SAMPLE = 2e-3  # white acceleration noise per sample, m/s^2


@pytest.fixture(scope="module")
def imu_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 5-minute static IMU record: gyros (deg/s) and accelerometers (m/s^2, g on z)."""
    rng = np.random.default_rng(3)
    n = 3000
    rate = rng.normal(0.0, 1e-3, (n, 3))
    accel = rng.normal(0.0, VRW_M_S2_PER_SAMPLE, (n, 3)) + [0.0, 0.0, STANDARD_GRAVITY_M_S2]
    return write_csv_record(tmp_path_factory.mktemp("imu") / "imu.csv", rate, RATE_HZ,
                            axis_names=("x", "y", "z"), accel_m_s2=accel)


def test_the_allan_plot_draws_accelerometers_in_their_own_units(imu_csv: Path) -> None:
    record = read_csv_record(imu_csv)
    assert record.accel_axis_names == ("accel_x", "accel_y", "accel_z")
    accel = analyze_record(record.select("accel_x"))
    assert [(a.name, a.accel is not None) for a in accel] == [("accel_x", True)]
    for unit, factor in (("m/s^2", 1.0), ("mg", 1e3 / STANDARD_GRAVITY_M_S2)):
        fig = allan_figure(accel[:1], accel_unit=unit)
        ax = fig.axes[0]
        assert ax.get_ylabel().endswith(f"[{unit}]")
        first = ax.lines[0].get_ydata()[0]  # the deviation at the shortest tau
        assert first == pytest.approx(VRW_M_S2_PER_SAMPLE * factor, rel=0.1)
    with pytest.raises(ValueError, match="separate Allan plots"):
        allan_figure([*analyze_rates(record.select("x")), accel[0]])


def test_the_wavelet_plot_draws_an_accelerometer_in_its_unit_squared(imu_csv: Path) -> None:
    (gmwm,) = analyze_record(read_csv_record(imu_csv).select("accel_x"), method="gmwm")
    ax = wavelet_figure([gmwm], accel_unit="ug").axes[0]
    assert ax.get_ylabel().endswith("[(ug)^2]")
    assert ax.lines[0].get_ydata()[0] == pytest.approx(
        (VRW_M_S2_PER_SAMPLE * 1e6 / STANDARD_GRAVITY_M_S2) ** 2 / 2, rel=0.3)  # WV = AVAR/2


def test_analyze_png_writes_the_accelerometers_beside_the_rates(imu_csv: Path,
                                                                 tmp_path: Path,
                                                                 capsys) -> None:
    png = tmp_path / "allan.png"
    assert main(["analyze", str(imu_csv), "--png", str(png)]) == 0
    assert png.stat().st_size > 10_000
    assert (tmp_path / "allan_accel.png").stat().st_size > 10_000
    assert "drawn in m/s^2" in capsys.readouterr().err


def test_davar_of_an_accelerometer_axis_is_in_m_s2(imu_csv: Path, tmp_path: Path,
                                                   capsys) -> None:
    png = tmp_path / "davar.png"
    assert main(["davar", str(imu_csv), "--axis", "accel_z", "--window-s", "200",
                 "--png", str(png), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    (axis,) = doc["axes"]
    assert axis["quantity"] == "acceleration" and "adev_deg_h" not in axis
    assert axis["adev_m_s2"][0][0] == pytest.approx(VRW_M_S2_PER_SAMPLE, rel=0.15)
    assert png.stat().st_size > 10_000


def test_reconcile_refuses_an_accelerometer_axis_in_one_line(imu_csv: Path, capsys) -> None:
    model = Path(__file__).resolve().parents[1] / "profiles" / "models" / "VG951.toml"
    assert main(["reconcile", str(imu_csv), "--axis", "accel_x", "--model", str(model)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "accelerometer axis 'accel_x'" in err
