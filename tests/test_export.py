"""station export: each tool's file read back with its own parser and checked against the
formulas."""

from __future__ import annotations

import json
import math
import os
import re
import runpy
import stat
import threading
from pathlib import Path

import numpy as np
import pytest
import yaml

from analysis.figures.tool_units import (
    AxisNoise,
    GaussMarkovBias,
    allan_floor,
    arw_deg_rt_h_from_density,
    bias_instability_from_floor,
    discrete_noise_std,
    discrete_random_walk_std,
    gauss_markov_driving_density,
    noise_density_deg_s_rt_hz,
    noise_density_rad_s_rt_hz,
    random_walk_rad_s2_rt_hz,
    rate_rad_s,
    rrw_deg_h_1_5_from_random_walk,
)
from analysis.models.noise import white_rate_noise
from analysis.units.conversions import arw_deg_rt_h_to_deg_rt_s
from station.cli import main
from station.errors import UsageError
from station.model.records import RateRecord
from station.output.export_formats import FORMATS, ExportContext, render
from station.services.export import ExportRequest, default_output, export_noise, noise_of
from station.services.records import RecordSource
from station.storage.atomic_files import write_text_atomically
from station.storage.csv_records import write_csv_record

D2R = math.pi / 180


# ------------------------------------------------------------------ the formulas


def test_noise_density_is_the_arw_in_radians_per_root_second() -> None:
    # 1 deg/sqrt(h) = 1/60 deg/sqrt(s) = (pi/180)/60 rad/s/sqrt(Hz)
    assert noise_density_rad_s_rt_hz(1.0) == pytest.approx(D2R / 60, rel=1e-15)
    assert noise_density_deg_s_rt_hz(0.3) == pytest.approx(0.005, rel=1e-15)
    assert arw_deg_rt_h_from_density(noise_density_rad_s_rt_hz(0.37)) == pytest.approx(
        0.37, rel=1e-14
    )
    # discrete: a sample at fs is the mean over 1/fs, variance density^2 * fs
    assert discrete_noise_std(1e-4, 400.0) == pytest.approx(2e-3, rel=1e-15)


def test_white_noise_of_a_density_has_that_allan_deviation_at_one_second() -> None:
    """The convention checked on data: white noise drawn as N sqrt(fs) per sample has
    sigma(1 s) = N."""
    fs, n = 50.0, 200_000
    density = noise_density_rad_s_rt_hz(0.5)
    x = np.random.default_rng(3).normal(0.0, discrete_noise_std(density, fs), n)
    means = x[: n // 50 * 50].reshape(-1, 50).mean(axis=1)  # 1 s averages
    adev_1s = math.sqrt(0.5 * np.mean(np.diff(means) ** 2))
    assert adev_1s == pytest.approx(density, rel=0.02)


def test_random_walk_and_bias_instability_conventions() -> None:
    assert random_walk_rad_s2_rt_hz(1.0) == pytest.approx(D2R / 3600**1.5, rel=1e-15)
    assert rrw_deg_h_1_5_from_random_walk(random_walk_rad_s2_rt_hz(12.5)) == pytest.approx(
        12.5, rel=1e-14
    )
    assert discrete_random_walk_std(1e-6, 100.0) == pytest.approx(1e-7, rel=1e-15)
    assert rate_rad_s(3600.0) == pytest.approx(D2R, rel=1e-15)
    # imu_utils / kalibr_allan's "bias instability" is the floor, 0.664 B
    assert allan_floor(10.0) == pytest.approx(6.64)
    assert bias_instability_from_floor(allan_floor(7.0)) == pytest.approx(7.0)
    # a Gauss-Markov state of std s, time T is driven by s sqrt(2/T)
    assert gauss_markov_driving_density(2.0, 50.0) == pytest.approx(0.4)
    with pytest.raises(ValueError, match="sample_rate_hz"):
        discrete_noise_std(1.0, 0.0)


# ------------------------------------------------------------------ the files, from known figures


def _axes(gauss_markov: bool = False) -> list[AxisNoise]:
    gm = (GaussMarkovBias(4.0, 30.0), GaussMarkovBias(9.0, 400.0)) if gauss_markov else ()
    return [
        AxisNoise(f"gyro_{c}", 200.0, arw, b, k, bias, gm if c != "y" else (), {"arw": "fit"})
        for c, arw, b, k, bias in (
            ("x", 0.2, 3.0, 5.0, 10.0),
            ("y", 0.3, 2.0, 7.0, -20.0),
            ("z", 0.25, 4.0, 6.0, 0.5),
        )
    ]


CTX = ExportContext(source="run.h5", unit="unit2", rostopic="/bench/imu")


@pytest.mark.parametrize("fmt", ["kalibr", "allan-variance-ros"])
def test_kalibr_style_yaml_reads_back_in_radians(fmt: str) -> None:
    data = yaml.safe_load(render(fmt, _axes(), CTX))
    # the largest over the axes: y's N (0.3 deg/sqrt(h)) and y's K (7 deg/h^1.5)
    assert data["gyroscope_noise_density"] == pytest.approx(0.3 * D2R / 60, rel=1e-12)
    assert data["gyroscope_random_walk"] == pytest.approx(7.0 * D2R / 3600**1.5, rel=1e-12)
    assert data["update_rate"] == 200.0 and data["rostopic"] == "/bench/imu"
    assert not any(k.startswith("accelerometer") for k in data)  # not measured: not invented


def test_openvins_chain_has_the_opencv_header_and_an_imu0_block() -> None:
    text = render("openvins", _axes(), CTX)
    first, _, rest = text.partition("\n")
    assert first.startswith("%YAML:1.0")  # OpenCV's FileStorage needs it; PyYAML reads the rest
    imu0 = yaml.safe_load(rest)["imu0"]
    assert imu0["gyroscope_noise_density"] == pytest.approx(
        noise_density_rad_s_rt_hz(0.3), rel=1e-12
    )
    assert imu0["gyroscope_random_walk"] == pytest.approx(random_walk_rad_s2_rt_hz(7.0), rel=1e-12)
    assert imu0["update_rate"] == 200.0 and imu0["time_offset"] == 0.0 and imu0["model"] == "kalibr"


def _matlab_call(text: str) -> dict[str, list[float]]:
    """The name-value pairs of the ``gyroparams(...)`` call, parsed as MATLAB would read them."""
    call = re.search(r"params = gyroparams\((.*)\);", text.replace("...\n", ""), re.S)
    assert call is not None
    pairs = re.findall(r"'(\w+)',\s*(\[[^\]]*\]|[-+0-9.eE]+)", call.group(1))
    return {k: [float(x) for x in v.strip("[]").split()] for k, v in pairs}


def test_matlab_script_and_json_hold_gyroparams_units() -> None:
    fields = _matlab_call(render("matlab", _axes(), CTX))
    from_json = json.loads(render("matlab", _axes(), CTX, suffix=".json"))
    for values in (fields, from_json):
        assert values["NoiseDensity"] == pytest.approx(
            [noise_density_rad_s_rt_hz(a) for a in (0.2, 0.3, 0.25)]
        )
        assert values["BiasInstability"] == pytest.approx([rate_rad_s(b) for b in (3.0, 2.0, 4.0)])
        assert values["RandomWalk"] == pytest.approx(
            [random_walk_rad_s2_rt_hz(k) for k in (5.0, 7.0, 6.0)]
        )
        assert values["ConstantBias"] == pytest.approx([rate_rad_s(b) for b in (10.0, -20.0, 0.5)])
    one = _matlab_call(render("matlab", _axes()[:1], CTX))
    assert one["NoiseDensity"] == pytest.approx([noise_density_rad_s_rt_hz(0.2)])  # a scalar
    with pytest.raises(UsageError, match="one axis or three"):
        render("matlab", _axes()[:2], CTX)


def test_gnss_ins_sim_module_runs_and_names_its_units(tmp_path: Path) -> None:
    path = tmp_path / "gyro_err.py"
    path.write_text(render("gnss-ins-sim", _axes(), CTX))
    err = runpy.run_path(str(path))["gyro_err"]
    assert set(err) == {"gyro_b", "gyro_arw", "gyro_b_stability"}  # no Gauss-Markov: no gyro_b_corr
    assert err["gyro_arw"].tolist() == [0.2, 0.3, 0.25]  # deg/sqrt(h)
    assert err["gyro_b_stability"].tolist() == [3.0, 2.0, 4.0]  # deg/h, B
    assert err["gyro_b"].tolist() == [10.0, -20.0, 0.5]
    path.write_text(render("gnss-ins-sim", _axes(gauss_markov=True), CTX))
    err = runpy.run_path(str(path))["gyro_err"]
    # the Gauss-Markov term of largest sigma on x and z; y has none: B and an infinite time
    assert err["gyro_b_stability"].tolist() == [9.0, 2.0, 9.0]
    assert err["gyro_b_corr"][[0, 2]].tolist() == [400.0, 400.0] and math.isinf(
        err["gyro_b_corr"][1]
    )
    with pytest.raises(UsageError, match="three axes"):
        render("gnss-ins-sim", _axes()[:1], CTX)


def test_json_names_every_unit() -> None:
    data = json.loads(render("json", _axes(gauss_markov=True), CTX))
    x = data["axes"][0]
    assert x["noise_density_rad_s_rt_hz"] == pytest.approx(noise_density_rad_s_rt_hz(0.2))
    assert x["noise_discrete_rad_s"] == pytest.approx(
        noise_density_rad_s_rt_hz(0.2) * math.sqrt(200)
    )
    assert x["allan_floor_deg_h"] == pytest.approx(0.664 * 3.0)
    assert x["gauss_markov"][1]["sigma_rad_s"] == pytest.approx(rate_rad_s(9.0))
    unitless = {"name", "sources", "gauss_markov"}
    units = ("_hz", "_deg_rt_h", "_rt_hz", "_rad_s", "_deg_h", "_1_5", "_s")
    assert all(k in unitless or k.endswith(units) for k in x)


def test_default_names_are_identifiers_where_the_tool_loads_them_as_code() -> None:
    assert default_output("a/b/run-7.h5", "matlab", "unit2").name == "run_7_unit2_gyro_params.m"
    assert default_output("2024 run.csv.gz", "gnss-ins-sim").name == "g_2024_run_gyro_err.py"
    assert default_output("run.csv", "kalibr").name == "run_imu.yaml"
    assert set(FORMATS) == {
        "kalibr",
        "openvins",
        "matlab",
        "gnss-ins-sim",
        "allan-variance-ros",
        "json",
    }


# ------------------------------------------------------------------ end to end


@pytest.fixture(scope="module")
def record_csv(tmp_path_factory) -> Path:
    fs, n = 50.0, 30_000
    rate = white_rate_noise(arw_deg_rt_h_to_deg_rt_s(0.4), n, fs, np.random.default_rng(11))
    return write_csv_record(tmp_path_factory.mktemp("exp") / "run.csv", rate, fs, axis_names=["x"])


def test_export_kalibr_from_a_record_matches_the_analysis(
    record_csv: Path, tmp_path: Path, capsys
) -> None:
    out = tmp_path / "imu.yaml"
    assert main(["export", str(record_csv), "--format", "kalibr", "--out", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    x = report["axes"][0]
    assert report["out"] == str(out) and x["arw_deg_rt_h"] == pytest.approx(0.4, rel=0.05)
    data = yaml.safe_load(out.read_text())
    assert data["gyroscope_noise_density"] == pytest.approx(
        noise_density_rad_s_rt_hz(x["arw_deg_rt_h"])
    )
    assert data["gyroscope_random_walk"] == pytest.approx(
        random_walk_rad_s2_rt_hz(x["rrw_deg_h_1_5"])
    )
    assert data["update_rate"] == 50.0
    # white noise only: K is not resolved, and its bound is what the file holds, said so
    assert "upper bound" in x["sources"]["rrw"]
    assert [p.name for p in tmp_path.iterdir()] == ["imu.yaml"]  # no temporary file left


def test_a_refused_export_leaves_the_previous_file_alone(
    record_csv: Path, tmp_path: Path, capsys
) -> None:
    out = tmp_path / "gyro_err.py"
    out.write_text("previous\n")
    assert main(["export", str(record_csv), "--format", "gnss-ins-sim", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "three axes" in err and "Traceback" not in err
    assert out.read_text() == "previous\n" and len(list(tmp_path.iterdir())) == 1


def test_atomic_write_refuses_a_missing_folder_and_leaves_nothing(tmp_path: Path) -> None:
    with pytest.raises(UsageError, match="no folder"):
        write_text_atomically(tmp_path / "nope" / "f.yaml", "x")
    (tmp_path / "d").mkdir()
    with pytest.raises(UsageError, match="is a folder"):
        write_text_atomically(tmp_path / "d", "x")
    assert write_text_atomically(tmp_path / "f.yaml", "a: 1\n").read_text() == "a: 1\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d", "f.yaml"]


def test_atomic_write_into_a_pipe_writes_through_it_and_keeps_it(tmp_path: Path) -> None:
    """An output named ``/dev/null``, ``/dev/stdout`` or a pipe is written in place: a
    rename over it would replace the device with a file (as root, ``--out /dev/null``
    turned the machine's /dev/null into a plain file)."""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    write_text_atomically(fifo, "a: 1\n")
    reader.join(10)
    assert got == [b"a: 1\n"] and stat.S_ISFIFO(fifo.stat().st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pipe"]  # no temporary left


def test_gmwm_export_gives_gnss_ins_sim_its_correlation_time(tmp_path: Path) -> None:
    """A white plus Gauss-Markov record: the GMWM's term becomes gyro_b_stability and
    gyro_b_corr."""
    fs, n, tau_s, sigma_deg_h = 10.0, 8000, 30.0, 10.0
    rng = np.random.default_rng(5)
    a = math.exp(-1.0 / (fs * tau_s))
    drive = rng.normal(0.0, sigma_deg_h / 3600 * math.sqrt(1 - a * a), n)
    gm = np.zeros(n)
    for i in range(1, n):
        gm[i] = a * gm[i - 1] + drive[i]
    rate = white_rate_noise(arw_deg_rt_h_to_deg_rt_s(0.2), n, fs, rng) + gm
    record = RateRecord(rate[:, None], fs, ("x",))
    ((axis, _),) = [(a.noise, a.earth_rate_removed) for a in noise_of(record, "gmwm", "wn+gm")]
    assert axis.sources and axis.sources["arw"] == "GMWM (wn+gm)"
    assert axis.main_gauss_markov is not None
    assert 0.5 * sigma_deg_h < axis.main_gauss_markov.sigma_deg_h < 2 * sigma_deg_h
    three = [
        AxisNoise(
            c,
            fs,
            axis.arw_deg_rt_h,
            axis.bias_instability_deg_h,
            axis.rrw_deg_h_1_5,
            axis.bias_deg_h,
            axis.gauss_markov,
        )
        for c in "xyz"
    ]
    path = tmp_path / "gyro_err.py"
    path.write_text(render("gnss-ins-sim", three, CTX))
    err = runpy.run_path(str(path))["gyro_err"]
    assert err["gyro_b_corr"].tolist() == [axis.main_gauss_markov.tau_s] * 3
    assert err["gyro_b_stability"].tolist() == [axis.main_gauss_markov.sigma_deg_h] * 3
    with pytest.raises(UsageError, match="--model goes with --method gmwm"):
        export_noise(ExportRequest(RecordSource("gm.csv"), "json", gmwm_model="wn+gm"))
