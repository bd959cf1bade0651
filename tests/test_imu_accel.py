"""Accelerometer axes of an IMU record (issue 30): CSV columns, the same analysis in m/s^2,
gravity off the bias, Kalibr's accelerometer keys, grading a velocity random walk.

Golden data: the real ADIS16405 static recording of ``../shared/real-data`` (SMAC-Group's
imudata, CC BY-NC-SA 4.0), gyro in deg/s and accelerometer in g, joined into one 6-column
CSV; a 60 s slice keeps each test short. The independent reference is allantools' OADEV.
"""

from __future__ import annotations

import gzip
import json
import math
from itertools import islice
from pathlib import Path

import numpy as np
import pytest
import yaml

from analysis.figures.accel import STANDARD_GRAVITY_M_S2, normal_gravity_m_s2, vertical_axis
from station.cli import main
from station.errors import BenchError, RecordFormatError
from station.services.export import ExportRequest, export_noise
from station.services.records import RecordSource
from station.storage.csv_records import read_csv_record

REAL_DATA = Path(__file__).resolve().parents[2] / "shared" / "real-data"
GYRO = REAL_DATA / "adis16405_imu1_gyro_deg_s_100hz.csv.gz"
ACCEL = REAL_DATA / "adis16405_imu1_accel_g_100hz.csv.gz"
ROWS = 6_000  # 60 s at 100 Hz
real = pytest.mark.skipif(not (GYRO.exists() and ACCEL.exists()),
                          reason="../shared/real-data (ADIS16405 gyro and accel) is not beside "
                                 "this checkout")


def _rows(path: Path) -> list[str]:
    with gzip.open(path, "rt") as fh:  # the header and ROWS rows, not the whole file
        return [line.strip() for line in islice((x for x in fh if not x.startswith("#")),
                                                ROWS + 1)]


@pytest.fixture(scope="module")
def imu_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The first 60 s of the ADIS16405 as one CSV: gyro_x,y,z (deg/s), accel_x,y,z (g)."""
    if not (GYRO.exists() and ACCEL.exists()):
        pytest.skip("../shared/real-data (ADIS16405 gyro and accel) is not beside this checkout")
    path = tmp_path_factory.mktemp("imu") / "adis16405_imu.csv"
    joined = [f"{g},{a}" for g, a in zip(_rows(GYRO), _rows(ACCEL), strict=True)]
    path.write_text("\n".join(joined) + "\n")
    return path


def test_normal_gravity_matches_wgs84_and_falls_with_height() -> None:
    # WGS-84 (NIMA TR8350.2 table 3.4): equator 9.7803253359, poles 9.8321849378 m/s^2
    assert normal_gravity_m_s2(0.0) == pytest.approx(9.7803253359, abs=1e-9)
    assert normal_gravity_m_s2(90.0) == pytest.approx(9.8321849378, abs=1e-8)
    # free-air gradient about -3.086e-6 s^-2 near the surface
    drop = normal_gravity_m_s2(45.0) - normal_gravity_m_s2(45.0, 1000.0)
    assert drop == pytest.approx(3.086e-3, rel=0.01)
    assert vertical_axis([0.01, -9.9, 0.2]) == 1


def test_accel_units_convert_and_bad_units_refused(tmp_path: Path) -> None:
    path = tmp_path / "r.csv"
    path.write_text("time,gyro_x,acc_z\n0,0.1,-1\n0.01,0.2,-1.5\n0.02,0.3,-0.5\n")
    rec = read_csv_record(path, accel_units="mg")
    assert rec.axis_names == ("gyro_x",) and rec.accel_axis_names == ("acc_z",)
    assert rec.accel_m_s2 is not None
    np.testing.assert_allclose(rec.accel_m_s2[:, 0], np.array([-1e-3, -1.5e-3, -0.5e-3])
                               * np.float64(STANDARD_GRAVITY_M_S2))
    with pytest.raises(RecordFormatError, match="'deg/s' is a rate unit"):
        read_csv_record(path, accel_units="deg/s")
    bad = tmp_path / "bad.csv"
    bad.write_text("time,gyro_x,accel_x_deg_s\n0,0.1,1\n0.01,0.2,1\n")
    with pytest.raises(RecordFormatError, match="accel_x_deg_s"):
        read_csv_record(bad)


def test_cli_refuses_unknown_accel_unit_in_one_line(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "r.csv"
    path.write_text("time,gyro_x,accel_x\n0,0.1,1\n0.01,0.2,1\n")
    assert main(["analyze", str(path), "--accel-units", "furlong"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "'furlong'" in err


def _oadev_at(x: np.ndarray, fs: float, tau_s: float) -> float:
    import allantools

    taus, adev, _, _ = allantools.oadev(x, rate=fs, data_type="freq", taus=[tau_s])
    assert taus[0] == pytest.approx(tau_s)
    return float(adev[0])


@real
@pytest.mark.slow
def test_imu_csv_gives_six_axes_and_kalibr_in_each_tools_units(imu_csv: Path) -> None:
    rec = read_csv_record(imu_csv, sample_rate_hz=100.0, accel_units="g")
    assert rec.accel_m_s2 is not None
    result = export_noise(ExportRequest(RecordSource(imu_csv, rate_hz=100.0, accel_units="g"),
                                        "kalibr", out=Path("-")))
    as_json = result.as_json()
    quantities = [a["quantity"] for a in as_json["accel_axes"]]  # type: ignore[union-attr, index]
    assert len(result.axes) == 3 and quantities == ["acceleration"] * 3
    doc = yaml.safe_load(result.text)
    # the white-noise level an independent estimator reads: sigma(tau) sqrt(tau) at 0.1 s,
    # past the ADIS's output filter and, for the accelerometer, before its quantization
    # dip (1-3 s), both where the white noise dominates
    gyro_rad = np.deg2rad(rec.rate_deg_s)
    gyro_n = max(_oadev_at(gyro_rad[:, i], 100.0, 0.1) * math.sqrt(0.1) for i in range(3))
    accel_n = max(_oadev_at(rec.accel_m_s2[:, i], 100.0, 0.1) * math.sqrt(0.1)
                  for i in range(3))
    assert doc["gyroscope_noise_density"] == pytest.approx(gyro_n, rel=0.10)
    assert doc["accelerometer_noise_density"] == pytest.approx(accel_n, rel=0.10)
    assert "accelerometer_random_walk" in doc and "gyroscope only" not in result.text


@real
def test_analyze_json_names_quantity_and_takes_gravity_off(imu_csv: Path, tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]
                                                           ) -> None:
    assert main(["analyze", str(imu_csv), "--rate", "100", "--accel-units", "g",
                 "--terms", "NK", "--json"]) == 0
    axes = json.loads(capsys.readouterr().out)["axes"]
    assert [a["quantity"] for a in axes] == ["rate"] * 3 + ["acceleration"] * 3
    z = axes[5]
    assert z["figures"]["gravity_removed_m_s2"] == pytest.approx(-STANDARD_GRAVITY_M_S2)
    # z reads about -1.017 g: what stays after -1 g is about -17 mg, far under 1 g
    assert abs(z["figures"]["accel_bias_mg"]) < 50
    assert z["figures"]["vrw_m_s_rt_h"] > 0 and z["deviation_unit"] == "m/s^2"


@real
def test_grade_adis16405_reports_velocity_random_walk(imu_csv: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    # the profile's 300 s warm-up would leave nothing of the 60 s slice: a profile copy
    # without it, on axis z alone to keep the test short (figures and limits as shipped)
    profile = tmp_path / "adis.toml"
    text = (Path(__file__).resolve().parents[1] / "profiles" / "ADIS16405.toml").read_text()
    profile.write_text(text.replace("warmup_s = 300.0", "warmup_s = 0.0")
                       .replace('axes = ["x", "y", "z"]', 'axes = ["z"]'))
    assert main(["grade", str(imu_csv), "--rate", "100", "--accel-units", "g", "--profile",
                 str(profile), "--json", "--no-store"]) in (0, 1)
    doc = json.loads(capsys.readouterr().out)
    axes = doc["units"][0]["axes"]
    accel = {k: v for k, v in axes.items() if v["quantity"] == "acceleration"}
    assert sorted(accel) == ["accel_z"] and axes["z"]["quantity"] == "rate"
    for axis in accel.values():
        vrw = axis["figures"]["accel_vrw"]
        # the data sheet's typical 0.2 m/s/sqrt(h); a unit within a factor 2 of it
        assert 0.1 < vrw["value"] < 0.4
        assert "accel_adev_min" in axis["figures"] and "arw" not in axis["figures"]


def test_accel_limit_on_gyro_only_record_is_one_line_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rng = np.random.default_rng(3)
    path = tmp_path / "gyro.csv"
    rate = rng.normal(0.0, 0.05, size=(3000, 3))
    np.savetxt(path, rate, delimiter=",", header="gyro_x,gyro_y,gyro_z", comments="")
    profile = tmp_path / "adis.toml"
    text = (Path(__file__).resolve().parents[1] / "profiles" / "ADIS16405.toml").read_text()
    profile.write_text(text.replace("warmup_s = 300.0", "warmup_s = 0.0"))
    assert main(["grade", str(path), "--rate", "100", "--profile", str(profile),
                 "--no-store"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "accel_vrw" in err and "no accelerometer" in err


@pytest.mark.slow
def test_matlab_accelparams_of_white_accelerometer_noise(tmp_path: Path) -> None:
    """White acceleration noise of density q (m/s^2/sqrt(Hz)) on a unit lying flat (z up,
    +1 g plus a 2 mg bias): accelparams' NoiseDensity is q and its ConstantBias the 2 mg
    with gravity taken off."""
    rng = np.random.default_rng(11)
    fs, n, q = 100.0, 20_000, 0.004
    accel = rng.normal(0.0, q * math.sqrt(fs), size=(n, 3))
    accel[:, 2] += STANDARD_GRAVITY_M_S2 * (1.0 + 2e-3)
    gyro = rng.normal(0.0, 0.05, size=(n, 1))
    path = tmp_path / "imu.csv"
    np.savetxt(path, np.column_stack([gyro, accel]), delimiter=",", comments="",
               header="gyro_x,accel_x,accel_y,accel_z")
    result = export_noise(ExportRequest(RecordSource(path, rate_hz=fs), "matlab",
                                        out=tmp_path / "p.json"))
    params = json.loads(result.text)["accelparams"]
    assert params["NoiseDensity"] == pytest.approx([q] * 3, rel=0.1)
    bias = np.array(params["ConstantBias"])
    assert bias[2] == pytest.approx(2e-3 * STANDARD_GRAVITY_M_S2, abs=5 * q * math.sqrt(fs / n))
    assert "aparams = accelparams(" in export_noise(
        ExportRequest(RecordSource(path, rate_hz=fs), "matlab", out=Path("-"))).text


def test_bench_gravity_is_normal_gravity_on_the_up_component(tmp_path: Path) -> None:
    from station.evaluation.accel_axes import gravity_on_axes
    from station.model.bench import load_bench

    path = tmp_path / "bench.toml"
    path.write_text('latitude_deg = 45.0\nheight_m = 1000.0\n'
                    '[axes]\nx = "north"\ny = [0.0, 0.6, -0.8]\nz = "down"\n')
    bench = load_bench(path)
    g = normal_gravity_m_s2(45.0, 1000.0)
    gravity, notes = gravity_on_axes(bench, ("accel_x", "accel_y", "accel_z"), [0.0, 0.0, 0.0])
    assert gravity == pytest.approx([0.0, -0.8 * g, -g])
    assert "1000 m" in notes[2]
    # no bench: the axis nearest 1 g is the vertical, at standard gravity, and it says so
    gravity, notes = gravity_on_axes(None, ("a", "b"), [9.7, 0.3])
    assert gravity == [STANDARD_GRAVITY_M_S2, 0.0] and "nearest +1 g" in notes[0]
    path.write_text('latitude_deg = 45.0\nheight_m = 1e6\n[axes]\nz = "up"\n')
    with pytest.raises(BenchError, match="height_m"):
        load_bench(path)


@pytest.mark.slow
def test_spec_sheets_draw_the_accelerometers_in_the_profiles_unit(imu_csv: Path,
                                                                   tmp_path: Path) -> None:
    """The PDF gains a page with the accelerometers' Allan deviation, the HTML a section,
    both in the mg the ADIS16405 profile gives its accelerometer Allan minimum in."""
    from station.model.profiles import parse_profile
    from station.output.report.panels import accel_plot_unit
    from station.services.grade import GradeRequest, RunSource
    from station.services.report import ReportRequest, report

    profile = tmp_path / "adis.toml"
    text = (Path(__file__).resolve().parents[1] / "profiles" / "ADIS16405.toml").read_text()
    profile.write_text(text.replace("warmup_s = 300.0", "warmup_s = 0.0")
                       .replace('axes = ["x", "y", "z"]', 'axes = ["z"]'))
    assert accel_plot_unit(parse_profile(profile.read_text())) == "mg"
    run = RunSource(imu_csv, rate_hz=100.0, accel_units="g")
    files = dict(report(ReportRequest(GradeRequest(run, str(profile), store=False),
                                      formats=("pdf", "html"), out_dir=tmp_path)).files)
    html = files["html"].read_text()
    assert "Allan deviation of the accelerometers" in html
    assert "DAVAR heat map per accelerometer axis" in html
    pdf = files["pdf"].read_bytes()
    assert pdf.count(b"/Type /Page\n") + pdf.count(b"/Type /Page ") >= 2  # sheet + accel page


def test_an_accelerometer_spike_is_said_in_m_s2(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """A 0.5 m/s^2 spike on accel_x: its size is in m/s^2 in the JSON and the notes (it was
    printed as m/s^2 x 3600 'deg/h')."""
    rng = np.random.default_rng(30)
    n = 6000
    gyro = rng.normal(0.0, 0.01, n)
    accel = rng.normal(0.0, 0.002, n)
    accel[3000] += 0.5
    path = tmp_path / "imu.csv"
    rows = "\n".join(f"{i / 100:.2f},{g:.6f},{a:.6f}" for i, (g, a) in
                     enumerate(zip(gyro, accel, strict=True)))
    path.write_text("time,gyro_x,accel_x\n" + rows + "\n")
    assert main(["analyze", str(path), "--json"]) == 0
    axes = {a["name"]: a for a in json.loads(capsys.readouterr().out)["axes"]}
    out = axes["accel_x"]["outliers"]
    assert out["count"] == 1 and "size_deg_h" not in out["spikes"][0]
    assert out["spikes"][0]["size_m_s2"] == pytest.approx(0.5, abs=0.02)
    notes = " ".join(axes["accel_x"]["figures"]["notes"])
    assert "m/s^2 at 30" in notes and "deg/h" not in notes.split("spikes:")[1]


def test_an_accelerometers_gmwm_terms_are_in_its_own_units(tmp_path: Path) -> None:
    """White noise of 0.002 m/s^2 per sample at 100 Hz: the GMWM's white-noise term on the
    sheets is the velocity random walk, 0.012 m/s/sqrt(h) (it was labelled deg/sqrt(h))."""
    from station.evaluation.gmwm_run import run_with_gmwm
    from station.output.report.gmwm_terms import gmwm_rows
    from station.services.grade import GradeRequest, RunSource, grade
    from tests.test_grading import profile_text, write_profile

    rng = np.random.default_rng(31)
    n = 20_000
    rows = "\n".join(f"{i / 100:.2f},{g:.6f},{a:.6f}" for i, (g, a) in
                     enumerate(zip(rng.normal(0, 0.01, n), rng.normal(0, 0.002, n),
                                   strict=True)))
    path = tmp_path / "imu.csv"
    path.write_text("time,x,accel_x\n" + rows + "\n")
    figures = """
[figures.arw]
unit = "deg/sqrt(h)"
limits = { A = 1.0, B = 2.0 }
[figures.accel_vrw]
unit = "m/s/sqrt(h)"
limits = { A = 1.0, B = 2.0 }
"""
    profile = write_profile(tmp_path, profile_text(warmup_s=0.0, figures=figures))
    graded = grade(GradeRequest(RunSource(path), profile=str(profile), store=False)).graded
    axes = {a.axis: a for a in run_with_gmwm(graded, "wn").units[0].axes}
    [gyro] = gmwm_rows(axes["x"])
    [accel] = gmwm_rows(axes["accel_x"])
    assert gyro.unit == "deg/sqrt(h)" and accel.unit == "m/s/sqrt(h)"
    assert accel.value == pytest.approx(0.002 / math.sqrt(100.0) * 60.0, rel=0.05)
    assert accel.ci_low is not None and accel.ci_low < accel.value < (accel.ci_high or 0.0)


@real
@pytest.mark.slow
def test_accelerometer_only_record_is_analysed_and_graded(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A CSV of the ADIS16405's accelerometer columns alone (in g): analysed (three
    acceleration axes, every VRW within a factor 2 of the data sheet's 0.2 m/s/sqrt(h),
    with its interval) and graded on its accelerometer figures, the unit saying that the
    profile's rate figures went ungraded."""
    path = tmp_path / "adis16405_accel.csv"
    path.write_text("\n".join(_rows(ACCEL)) + "\n")
    assert main(["analyze", str(path), "--rate", "100", "--accel-units", "g", "--json"]) == 0
    axes = json.loads(capsys.readouterr().out)["axes"]
    assert [a["quantity"] for a in axes] == ["acceleration"] * 3
    for a in axes:
        f = a["figures"]
        assert 0.1 < f["vrw_m_s_rt_h"] < 0.4
        assert f["vrw_ci_m_s_rt_h"][0] <= f["vrw_m_s_rt_h"] <= f["vrw_ci_m_s_rt_h"][1]
    profile = tmp_path / "adis.toml"
    text = (Path(__file__).resolve().parents[1] / "profiles" / "ADIS16405.toml").read_text()
    profile.write_text(text.replace("warmup_s = 300.0", "warmup_s = 0.0"))
    assert main(["grade", str(path), "--rate", "100", "--accel-units", "g", "--profile",
                 str(profile), "--json", "--no-store"]) in (0, 1)
    unit = json.loads(capsys.readouterr().out)["units"][0]
    assert sorted(unit["axes"]) == ["accel_x", "accel_y", "accel_z"]
    for axis in unit["axes"].values():
        vrw = axis["figures"]["accel_vrw"]
        assert 0.1 < vrw["value"] < 0.4 and vrw["ci_low"] is not None
    assert any("rate figure(s) bias, arw, adev_min are not measured" in n for n in unit["notes"])


def test_accelerometer_table_shows_intervals_and_bounds(tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    """White acceleration noise only: the accelerometer table gives the VRW read-off's
    interval and taus, and each fitted term the record does not resolve as 0 with its
    bound (it printed K and B as bare numbers); the Kalibr file marks a random walk that
    is only such a bound."""
    rng = np.random.default_rng(38)
    n = 20_000
    path = tmp_path / "imu.csv"
    np.savetxt(path, np.column_stack([rng.normal(0, 0.01, n), rng.normal(0, 0.002, (n, 3))]),
               delimiter=",", header="gyro_x,accel_x,accel_y,accel_z", comments="")
    assert main(["analyze", str(path), "--rate", "100"]) == 0
    out = capsys.readouterr().out
    table = out[out.index("accelerometers"):]
    assert "  interval [m/s/sqrt(h)]" in table and "  from tau [s]" in table
    k_row = next(line for line in table.splitlines() if line.startswith("fit K accel."))
    assert k_row.count("0 (<= ") == 3
    result = export_noise(ExportRequest(RecordSource(path, rate_hz=100.0), "kalibr",
                                        out=Path("-")))
    rw_line = next(line for line in result.text.splitlines()
                   if line.startswith("accelerometer_random_walk"))
    assert "UPPER BOUND" in rw_line
    assert any("accel_random_walk written as an upper bound" in n for n in result.notes)
