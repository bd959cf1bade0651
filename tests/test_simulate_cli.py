"""``station simulate`` and ``station model``: files written, JSON printed, errors reported."""

from __future__ import annotations

import argparse
import gzip
import io
import json
import sys

import numpy as np
import pytest

from analysis.allan.estimators import log_m
from analysis.models.fog import fog_from_indicators
from analysis.models.simulation import GyroSimulator
from devices.model_files import load_noise_model
from station import cli
from station.commands.arguments import duration_type
from station.services import simulate as simulate_service
from station.storage.csv_records import read_csv_record
from station.storage.hdf5 import read_run, read_run_record


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    rc = cli.main(list(argv))
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_simulate_a_preset_writes_the_simulators_run(tmp_path, capsys):
    out = tmp_path / "run.csv"
    rc, _, err = _run(capsys, "simulate", "--model", "VG951", "--duration", "2min", "--rate", "10",
                      "--seed", "1", "--axes", "2", "--out", str(out))
    assert rc == 0, err
    record = read_csv_record(out)
    assert record.rate_deg_s.shape == (1200, 2) and record.sample_rate_hz == pytest.approx(10.0)
    want = GyroSimulator(load_noise_model("VG951"), 10.0, n_axes=2, seed=1).read(1200)
    np.testing.assert_array_equal(record.rate_deg_s, want.rate_deg_s)  # %.17g round-trips float64
    assert "[bias_instability]" in out.read_text(encoding="utf-8").split("time,")[0]


def test_long_runs_are_written_in_chunks_identical_to_one_piece(tmp_path, capsys, monkeypatch):
    args = [
        "simulate",
        "--model",
        "mems-typical",
        "--duration",
        "500s",
        "--rate",
        "20",
        "--seed",
        "4",
    ]
    whole, pieces = tmp_path / "whole.csv", tmp_path / "pieces.csv.gz"
    assert _run(capsys, *args, "--out", str(whole))[0] == 0
    monkeypatch.setattr(simulate_service, "CHUNK_SAMPLES", 3001)
    rc, _, err = _run(capsys, *args, "--out", str(pieces))
    assert rc == 0
    # stderr is not a terminal here (a log file, a pipe): no progress, no carriage returns
    assert "\r" not in err and err == f"wrote 10000 samples x 1 axis at 20 Hz to {pieces}\n"
    with gzip.open(pieces, "rt", encoding="utf-8") as fh:
        assert fh.read() == whole.read_text(encoding="utf-8")
    record = read_csv_record(pieces)
    assert record.temperature_c is not None and record.n_samples == 10000


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_shows_on_a_terminal_with_its_eta_and_quiet_silences_it(tmp_path, monkeypatch):
    monkeypatch.setattr(simulate_service, "CHUNK_SAMPLES", 3001)
    args = [
        "simulate",
        "--model",
        "VG951",
        "--duration",
        "500s",
        "--rate",
        "20",
        "--seed",
        "4",
        "--axes",
        "3",
    ]
    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    assert cli.main([*args, "--out", str(tmp_path / "a.csv")]) == 0
    shown = terminal.getvalue()
    assert "\r" in shown and "ETA" in shown and "100.0 % (10000 of 10000 samples)" in shown
    assert "x 3 axes at 20 Hz" in shown
    quiet = _Terminal()
    monkeypatch.setattr(sys, "stderr", quiet)
    assert cli.main([*args, "--quiet", "--json", "--out", str(tmp_path / "b.csv")]) == 0
    assert "\r" not in quiet.getvalue()


def test_simulate_from_two_indicators(tmp_path, capsys):
    out = tmp_path / "fog.csv"
    rc, _, err = _run(
        capsys,
        "simulate",
        "--arw",
        "0.01",
        "--bias-stability",
        "0.1",
        "--average-s",
        "100",
        "--correlation-s",
        "50",
        "--duration",
        "1h",
        "--rate",
        "1",
        "--seed",
        "3",
        "--out",
        str(out),
    )
    assert rc == 0, err
    record = read_csv_record(out)
    model = fog_from_indicators(0.01, 0.1, average_s=100.0, correlation_s=50.0).noise_model()
    want = GyroSimulator(model, 1.0, seed=3).read(3600)
    np.testing.assert_array_equal(record.rate_deg_s, want.rate_deg_s)


def test_simulate_writes_a_run_file_in_the_recorders_layout(tmp_path, capsys, monkeypatch):
    out = tmp_path / "run.h5"
    monkeypatch.setattr(simulate_service, "CHUNK_SAMPLES", 700)
    rc, _, err = _run(
        capsys,
        "simulate",
        "--model",
        "mems-typical",
        "--duration",
        "200s",
        "--rate",
        "10",
        "--seed",
        "8",
        "--axes",
        "3",
        "--out",
        str(out),
    )
    assert rc == 0, err
    record = read_run_record(out)
    want = GyroSimulator(load_noise_model("mems-typical"), 10.0, n_axes=3, seed=8).read(2000)
    np.testing.assert_array_equal(record.rate_deg_s, want.rate_deg_s)
    np.testing.assert_array_equal(record.temperature_c, want.temperature_c)
    assert record.axis_names == ("gyro_x", "gyro_y", "gyro_z") and record.sample_rate_hz == 10.0
    info = read_run(out)
    assert not info.interrupted and info.units[0].model == "mems-typical"
    rc, _, err = _run(
        capsys, "simulate", "--model", "VG951", "--duration", "10s", "--out", str(out)
    )
    assert rc == 2 and "never overwritten" in err


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["--model", "VG951", "--out", "x.txt"], "must be .csv, .csv.gz or .h5"),
        (["--model", "VG951", "--arw", "1", "--out", "x.csv"], "not both"),
        (["--arw", "1", "--out", "x.csv"], "both --arw and --bias-stability"),
        (["--model", "no-such-gyro", "--out", "x.csv"], "no model file or preset"),
        (
            ["--arw", "0.05", "--bias-stability", "0.1", "--average-s", "10", "--out", "x.csv"],
            "not above what the ARW alone gives",
        ),
    ],
)
def test_simulate_errors_are_reported_not_raised(tmp_path, capsys, monkeypatch, argv, fragment):
    monkeypatch.chdir(tmp_path)
    rc, _, err = _run(capsys, "simulate", *argv)
    assert rc == 2
    assert fragment in err
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("text", "seconds"),
    [
        ("90", 90.0),
        ("90s", 90.0),
        ("2.5min", 150.0),
        ("4h", 14400.0),
        ("1d", 86400.0),
        ("1e3s", 1000.0),
    ],
)
def test_durations(text, seconds):
    assert duration_type(text) == seconds


@pytest.mark.parametrize("text", ["", "h", "-1h", "0", "4 hours", "4x"])
def test_bad_durations(text):
    with pytest.raises(argparse.ArgumentTypeError):
        duration_type(text)


def test_model_curve_json_is_the_theoretical_allan_deviation(capsys):
    rc, out, _ = _run(capsys, "model", "curve", "zhang2015-fog", "--taus", "log", "--json")
    assert rc == 0
    doc = json.loads(out)
    assert set(doc) == {"tau_s", "adev", "terms", "adev_deg_h", "terms_deg_h"}
    np.testing.assert_allclose(doc["adev_deg_h"], 3600 * np.array(doc["adev"]), rtol=1e-12)
    model = load_noise_model("zhang2015-fog")
    tau = np.array(doc["tau_s"])
    np.testing.assert_allclose(tau, log_m(4 * 3600 * 10) / 10.0)  # default: 4 h at 10 Hz
    np.testing.assert_allclose(doc["adev"], model.adev(tau), rtol=1e-12)
    assert list(doc["terms"]) == list(model.term_names)
    total = np.sum([np.square(v) for v in doc["terms"].values()], axis=0)
    np.testing.assert_allclose(np.square(doc["adev"]), total, rtol=1e-12)


def test_model_curve_explicit_taus_table_and_file(tmp_path, capsys):
    path = tmp_path / "m.toml"
    path.write_text(
        "[arw]\nN_deg_rt_h = 60.0\n[sinusoid]\namplitude_deg_h = 1.0\nperiod_s = 2.0\n",
        encoding="utf-8",
    )
    rc, out, _ = _run(capsys, "model", "curve", str(path), "--taus", "2,4", "--json")
    doc = json.loads(out)
    assert rc == 0 and doc["tau_s"] == [2.0, 4.0]
    np.testing.assert_allclose(doc["terms"]["arw"], [0.5**0.5, 0.5])  # 1 deg/sqrt(s) / sqrt(tau)
    np.testing.assert_allclose(doc["terms"]["sinusoid"], [0.0, 0.0], atol=1e-12)
    rc, out, _ = _run(capsys, "model", "curve", str(path), "--taus", "octave", "--duration", "60s")
    assert rc == 0 and "tau_s" in out and "sinusoid" in out and len(out.splitlines()) == 2 + 9
    rc, _, err = _run(capsys, "model", "curve", str(path), "--taus", "1,x")
    assert rc == 2 and "--taus must be" in err


def test_model_fog_writes_a_model_that_loads_back(tmp_path, capsys):
    out = tmp_path / "fog.toml"
    rc, _, _ = _run(
        capsys, "model", "fog", "--arw", "0.001", "--bias-stability", "0.007", "--out", str(out)
    )
    assert rc == 0
    assert load_noise_model(out) == fog_from_indicators(0.001, 0.007).noise_model()
    rc, text, _ = _run(capsys, "model", "show", str(out))
    assert rc == 0 and "[gauss_markov]" in text and "tau_s = 100.0" in text
