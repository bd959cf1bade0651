"""Command-line conventions: no abbreviations, one-line errors with exit 2, --version,
shell completion, and what a new user tripped over in reconcile."""

from __future__ import annotations

import argparse
import csv
import json
import re
import warnings
from pathlib import Path
from urllib.parse import urlsplit

import numpy as np
import pytest

from analysis.errors import FitError
from analysis.fit.least_squares import check_terms
from analysis.reconcile.discrepancy import measure_curve
from devices.url_query import check_keys, parse_query
from devices.urls import SUPPORTED, _allowed_keys
from station.cli import build_parser, main
from station.commands.conventions import enable_completion, report_unexpected
from station.model.version import software_version
from station.storage.csv_records import write_csv_record


@pytest.fixture(scope="module")
def run_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("conv") / "v.h5"
    assert (
        main(
            [
                "simulate",
                "--model",
                "VG951",
                "--duration",
                "10min",
                "--rate",
                "10",
                "--seed",
                "1",
                "--out",
                str(path),
            ]
        )
        == 0
    )
    return path


def _one_line_error(capsys, argv: list[str]) -> str:
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "usage:" not in err
    return err


def test_version(capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["--version"])
    assert exit_info.value.code == 0
    assert capsys.readouterr().out.strip() == f"station {software_version()}"


def test_no_option_is_abbreviated_anywhere(capsys) -> None:
    parser = build_parser()
    sub = next(a for a in parser._actions if hasattr(a, "choices") and isinstance(a.choices, dict))
    assert not parser.allow_abbrev and all(not p.allow_abbrev for p in sub.choices.values())
    err = _one_line_error(capsys, ["analyze", "rec.csv", "--war", "10"])  # not --warmup-s
    assert err.startswith("station analyze: error: unrecognized arguments: --war")
    err = _one_line_error(capsys, ["analyze", "rec.csv", "--units", "furlongs"])
    assert "invalid choice" in err and "station analyze --help" in err


def test_reconcile_takes_unit_and_time_slice_like_analyze(run_file: Path, capsys) -> None:
    # the new user's line: --unit is reconcile's own option now, never an abbreviation of --units
    assert main(["reconcile", str(run_file), "--model", "VG951", "--unit", "unit2"]) == 2
    err = capsys.readouterr().err
    assert err.strip() == f"station reconcile: error: {run_file}: no unit 'unit2'; units: sim"
    assert (
        main(
            [
                "reconcile",
                str(run_file),
                "--model",
                "VG951",
                "--unit",
                "sim",
                "--start-s",
                "60",
                "--runs",
                "4",
                "--json",
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    assert "(5400 samples)" in err and "reconciled 60 s .. end" in err


def test_constant_temperature_channel_raises_no_warning() -> None:
    rate = np.random.default_rng(1).normal(0.0, 0.01, 4096)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the RuntimeWarning of a 0/0 slope reached users
        curve = measure_curve(rate, 10.0, temperature_c=np.full(4096, 25.0))
    assert curve.temperature_c is None
    varying = measure_curve(rate, 10.0, temperature_c=np.linspace(20, 30, 4096))
    assert varying.temperature_c is not None


def test_unexpected_errors_are_one_line(capsys) -> None:
    assert report_unexpected("analyze", ValueError("boom")) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "internal error: ValueError: boom" in err
    assert report_unexpected("export", PermissionError(13, "Permission denied", "/x/y")) == 2
    assert capsys.readouterr().err == "station export: error: Permission denied: /x/y\n"


def test_shell_completion_answers_the_shell(tmp_path: Path, monkeypatch) -> None:
    out = tmp_path / "completions"
    for key, value in {
        "_ARGCOMPLETE": "1",
        "COMP_LINE": "station export x --for",
        "COMP_POINT": "22",
        "_ARGCOMPLETE_STDOUT_FILENAME": str(out),
    }.items():
        monkeypatch.setenv(key, value)
    codes: list[int] = []
    enable_completion(build_parser(), exit_method=codes.append)
    assert codes == [0] and out.read_text().split("\v") == ["--format "]
    monkeypatch.delenv("_ARGCOMPLETE")
    enable_completion(build_parser(), exit_method=codes.append)  # no request: nothing happens
    assert codes == [0]


def _parsers(parser: argparse.ArgumentParser, name: str = "station"):
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub_name, sub in action.choices.items():
                yield from _parsers(sub, f"{name} {sub_name}")


def test_help_is_plain_text_with_a_line_for_every_option() -> None:
    for name, parser in _parsers(build_parser()):
        missing = [
            a.option_strings or a.dest
            for a in parser._actions
            if a.help is None and not isinstance(a, argparse._SubParsersAction)
        ]
        assert not missing, f"{name}: options without help: {missing}"
        text = parser.format_help()
        assert not re.search(r":\w+:`|``", text), f"{name}: reStructuredText markup in its help"


@pytest.mark.parametrize(
    ("terms", "named"),
    [
        ("QNX", "'X' is not one of Q (quantization)"),
        ("XYZ", "'X', 'Y', 'Z' are not one of"),
        ("", "no letter is one of"),
    ],
)
def test_terms_name_what_is_wrong_and_the_valid_letters(terms: str, named: str) -> None:
    with pytest.raises(FitError, match=re.escape(named)):
        check_terms(terms)
    assert check_terms("knb") == "NBK"


def test_devices_lists_each_protocol_real_hardware_url_with_keys_it_accepts(capsys) -> None:
    assert main(["devices", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert len(listed) == len(SUPPORTED)
    for entry in listed:
        url = entry["hardware_url"]
        parts = urlsplit(url)
        assert parts.scheme == entry["transport"] and entry["sim_url"].startswith("sim+")
        query = parse_query(parts.query, url)
        check_keys(query, _allowed_keys(entry["transport"], False, query), url)  # raises if not
    assert main(["devices"]) == 0
    text = capsys.readouterr().out
    assert text.count("hardware:  ") == len(SUPPORTED) == text.count("simulated: ")


def test_analyze_writes_the_curve_as_csv_without_a_profile(tmp_path: Path, capsys) -> None:
    rate = np.random.default_rng(2).normal(0.0, 0.01, (6000, 2))
    record = write_csv_record(tmp_path / "r.csv", rate, 10.0, axis_names=["x", "y"])
    out_csv = tmp_path / "curve.csv"
    assert main(["analyze", str(record), "--csv", str(out_csv), "--json"]) == 0
    axes = json.loads(capsys.readouterr().out)["axes"]
    with out_csv.open() as fh:
        rows = list(csv.DictReader(fh))
    for axis in axes:
        mine = [r for r in rows if r["axis"] == axis["name"]]
        assert [float(r["tau_s"]) for r in mine] == axis["tau_s"]
        np.testing.assert_allclose(
            [float(r["oadev_deg_h"]) for r in mine], axis["adev_deg_h"], rtol=1e-12
        )
        np.testing.assert_allclose(axis["adev_deg_h"], np.array(axis["adev"]) * 3600, rtol=1e-12)
        assert all(float(r["fit_adev_deg_h"]) > 0 for r in mine)


def test_recover_and_simulate_print_json(run_file: Path, tmp_path: Path, capsys) -> None:
    assert main(["recover", str(run_file), "--json"]) == 0
    answer = json.loads(capsys.readouterr().out)
    assert answer["already_closed"] is True and answer["path"] == str(run_file)
    assert (
        main(
            [
                "simulate",
                "--model",
                "VG951",
                "--duration",
                "30s",
                "--axes",
                "3",
                "--seed",
                "2",
                "--json",
                "--out",
                str(tmp_path / "s.csv"),
            ]
        )
        == 0
    )
    captured = capsys.readouterr()
    assert json.loads(captured.out) == {
        "out": str(tmp_path / "s.csv"),
        "n_samples": 300,
        "axes": 3,
        "rate_hz": 10.0,
        "model": "VG951",
    }
    assert captured.err == ""
