"""Output unit families: the same run printed in deg and in rad (``--output-units``), figures
that convert exactly into each other, tables and spec sheets that name the rad units."""

from __future__ import annotations

import csv
import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from pypdf import PdfReader

from analysis.figures import tool_units
from analysis.units.conversions import (
    FAMILY_UNITS,
    RAD_FAMILY,
    family_unit,
    family_unit_of_key,
    unit_family,
)
from station.cli import main
from station.evaluation.grading import RunGrade, grade_run
from station.model.profiles import load_profile
from station.output.json_units import to_rad_family
from station.output.report import write_report
from station.storage.runs import open_run
from tests.test_grading import make_record, profile_text, write_profile

FIGURES = """
[figures.arw]
unit = "deg/sqrt(h)"
limits = { A = 0.06, B = 0.2 }

[figures.bias_instability]
unit = "deg/h"
limits = { A = 1.0, B = 3.0 }

[figures.bias]
unit = "deg/s"

[figures.rrw]
unit = "deg/h^1.5"
"""
RAD_UNITS = ("rad/s", "rad/s/sqrt(Hz)", "rad/s^2/sqrt(Hz)", "rad/s^2", "rad")


def test_family_factors_are_the_tool_conversions() -> None:
    """One factor per unit, equal to the formulas the export files are checked against."""
    rad = RAD_FAMILY
    assert rad.value(2.5, "deg/sqrt(h)") == pytest.approx(
        tool_units.noise_density_rad_s_rt_hz(2.5), rel=1e-15)
    assert rad.value(150.0, "deg/h^1.5") == pytest.approx(
        tool_units.random_walk_rad_s2_rt_hz(150.0), rel=1e-15)
    assert rad.value(3.0, "deg/h") == pytest.approx(3.0 * math.pi / 180 / 3600, rel=1e-15)
    assert rad.value(3.0, "deg/s") == pytest.approx(3.0 * math.pi / 180, rel=1e-15)
    assert rad.value(7.0, "deg/h^2") == pytest.approx(7.0 * math.pi / 180 / 3600**2, rel=1e-15)
    assert rad.value(7.0, "urad") == pytest.approx(7e-6, rel=1e-15)
    assert rad.label("s") == "s" and rad.value(4.0, "s") == 4.0  # not a deg-family unit
    assert unit_family("deg").value(3.0, "deg/h") == 3.0
    with pytest.raises(ValueError, match="deg, rad"):
        unit_family("grad")
    for u in FAMILY_UNITS:  # every key names its unit the way docs/json.md lists it
        assert family_unit(u.label) is u
        assert family_unit_of_key(f"x_{u.key}_stderr") == ("x", u, "_stderr")
    assert family_unit_of_key("tau_s") is None and family_unit_of_key("sample_rate_hz") is None


def test_json_document_to_rad_family() -> None:
    doc = {"tau_s": [1.0, 2.0], "adev": [1.0], "adev_deg_h": [3600.0], "adev_deg_s": [1.0],
           "fit": {"terms": "NK", "N_deg_rt_h_stderr": 60.0},
           "arw": {"label": "ARW", "unit": "deg/sqrt(h)", "value": 60.0, "limits": {"A": 120.0},
                   "verdict": "pass", "terms": "NK",
                   "alternatives": [{"terms": "NR", "value": 0.0, "ci_low": 0.0,
                                     "ci_high": 60.0}]},
           "deviation_unit": "deg/s", "model_after": {"arw_deg_rt_h": 1.0}}
    out = to_rad_family(doc)
    assert isinstance(out, dict)
    assert out["tau_s"] == [1.0, 2.0] and "adev" not in out and "adev_deg_h" not in out
    assert out["adev_rad_s"] == pytest.approx([math.pi / 180])
    assert out["fit"] == {"terms": "NK", "N_rad_s_rt_hz_stderr": pytest.approx(math.pi / 180)}
    assert out["arw"]["unit"] == "rad/s/sqrt(Hz)" and out["arw"]["verdict"] == "pass"
    assert out["arw"]["limits"]["A"] == pytest.approx(2 * math.pi / 180)
    # the figure's other readings are in its unit too
    assert out["arw"]["alternatives"] == [{"terms": "NR", "value": 0.0, "ci_low": 0.0,
                                           "ci_high": pytest.approx(math.pi / 180)}]
    assert out["arw"]["terms"] == "NK"
    assert out["deviation_unit"] == "rad/s"
    assert out["model_after"] == {"arw_deg_rt_h": 1.0}  # a model file's tables, as read


def _pairs(deg: object, rad: object, path: str = "") -> list[tuple[str, float, float, float]]:
    """(where, deg value, rad value, factor) for every quantity of a deg document and its rad
    twin; asserts the two have the same shape otherwise."""
    found = []
    if isinstance(deg, dict):
        assert isinstance(rad, dict)
        unit = family_unit(deg["unit"]) if isinstance(deg.get("unit"), str) else None
        for key, value in deg.items():
            split = family_unit_of_key(key)
            if split is not None:
                stem, u, tail = split
                found += _scaled_pairs(value, rad[f"{stem}_{u.rad_key}{tail}"], u.rad_per_deg,
                                       f"{path}/{key}")
            elif unit is not None and key in ("value", "ci_low", "ci_high", "limit", "limits"):
                found += _scaled_pairs(value, rad[key], unit.rad_per_deg, f"{path}/{key}")
            elif key in rad:
                found += _pairs(value, rad[key], f"{path}/{key}")
    elif isinstance(deg, list):
        assert isinstance(rad, list) and len(deg) == len(rad)
        for i, (d, r) in enumerate(zip(deg, rad, strict=True)):
            found += _pairs(d, r, f"{path}[{i}]")
    return found


def _scaled_pairs(deg: object, rad: object, factor: float, path: str):
    if isinstance(deg, int | float) and not isinstance(deg, bool):
        assert isinstance(rad, float)
        return [(path, float(deg), rad, factor)]
    if isinstance(deg, dict):
        assert isinstance(rad, dict)
        return [p for k in deg for p in _scaled_pairs(deg[k], rad[k], factor, f"{path}/{k}")]
    if isinstance(deg, list):
        assert isinstance(rad, list)
        return [p for i, (d, r) in enumerate(zip(deg, rad, strict=True))
                for p in _scaled_pairs(d, r, factor, f"{path}[{i}]")]
    assert deg is None and rad is None, path
    return []


def _assert_exact(pairs: list[tuple[str, float, float, float]]) -> None:
    for where, d, r, factor in pairs:
        assert r == pytest.approx(d * factor, rel=1e-13, abs=0.0), where


@pytest.fixture(scope="module")
def record_csv(tmp_path_factory) -> Path:
    return make_record(tmp_path_factory.mktemp("units") / "unit.csv", n=9_000, seed=5, n_axes=2)


@pytest.mark.slow
def test_analyze_in_deg_and_rad_convert_exactly(record_csv: Path, capsys) -> None:
    # axis x alone: axis y goes through the same conversions (two axes doubled the time)
    assert main(["analyze", str(record_csv), "--axis", "x", "--json"]) == 0
    deg = json.loads(capsys.readouterr().out)
    assert main(["analyze", str(record_csv), "--axis", "x", "--json", "--output-units",
                 "rad"]) == 0
    rad = json.loads(capsys.readouterr().out)
    pairs = _pairs(deg, rad)
    keys = {where.rsplit("/", 1)[-1].split("[")[0] for where, *_ in pairs}
    assert {"bias_deg_h", "arw_deg_rt_h", "N_deg_rt_h", "K_deg_h_1_5_stderr", "Q_urad",
            "adev_deg_h", "bias_instability_ci_deg_h"} <= keys
    assert len(pairs) > 200  # the curves too
    _assert_exact(pairs)
    axis = rad["axes"][0]
    assert "adev" not in axis and "bias_deg_h" not in axis["figures"]
    assert not [k for k in json.dumps(rad).split('"') if k.endswith(("_deg_h", "_deg_rt_h"))]
    # a rad table names the rad units in its row heads, and no deg unit
    assert main(["analyze", str(record_csv), "--axis", "x", "--output-units", "rad"]) == 0
    table = capsys.readouterr().out
    heads = [head for line in table.splitlines()
             if (head := line.strip().split("  ")[0]).endswith("]")]
    for head in ("bias [rad/s]", "ARW read-off [rad/s/sqrt(Hz)]", "fit Q quantization [rad]",
                 "fit K rate random walk [rad/s^2/sqrt(Hz)]", "fit R rate ramp [rad/s^2]"):
        assert any(h.startswith(head) for h in heads), head
    assert not [h for h in heads if "deg" in h or "urad" in h]
    # the option is checked: a bad family is one line and exit status 2
    with pytest.raises(SystemExit) as exc:
        main(["analyze", str(record_csv), "--output-units", "grad"])
    assert exc.value.code == 2


@pytest.fixture(scope="module")
def graded(record_csv: Path, tmp_path_factory) -> RunGrade:
    d = tmp_path_factory.mktemp("units-profile")
    profile = load_profile(write_profile(
        d, profile_text(axes='["x", "y"]', warmup_s=30.0, figures=FIGURES)))
    return grade_run(open_run(record_csv), profile)


def test_spec_sheet_in_rad(graded: RunGrade, tmp_path: Path) -> None:
    rad = replace(graded, output_units=RAD_FAMILY)
    deg_doc = json.loads(write_report(graded, "json", tmp_path / "deg").read_text())
    rad_doc = json.loads(write_report(rad, "json", tmp_path / "rad").read_text())
    pairs = _pairs(deg_doc, rad_doc)
    assert any(w.endswith("/arw/limits/A") for w, *_ in pairs)
    _assert_exact(pairs)
    x = rad_doc["units"][0]["axes"]["x"]
    assert x["figures"]["arw"]["unit"] == "rad/s/sqrt(Hz)"
    assert x["info"]["bias"]["unit"] == "rad/s" and x["info"]["rrw"]["unit"] == "rad/s^2/sqrt(Hz)"
    assert "adev_rad_s" in x["allan"] and "N_rad_s_rt_hz" in x["fit"]
    with write_report(rad, "csv", tmp_path / "rad").open(encoding="utf-8") as fh:
        row = next(csv.DictReader(fh))
    assert row["arw_unit"] == "rad/s/sqrt(Hz)" and "earth_rate_removed_rad_s" in row
    arw = graded.units[0].axis("x").figures[0]
    assert float(row["arw_value"]) == pytest.approx(
        tool_units.noise_density_rad_s_rt_hz(arw.value), rel=1e-13)
    text = PdfReader(write_report(rad, "pdf", tmp_path / "rad")).pages[0].extract_text()
    assert "rad/s/sqrt(Hz)" in text and "Allan deviation [rad/s]" in text
    assert "deg/sqrt(h)" not in text and "deg/h" not in text


@pytest.mark.slow
def test_grade_and_report_commands_take_output_units(record_csv: Path, graded: RunGrade,
                                                     tmp_path: Path, capsys) -> None:
    profile = graded.profile.path
    args = ["grade", str(record_csv), "--profile", profile, "--no-store"]
    assert main([*args, "--output-units", "rad"]) == 0
    table = capsys.readouterr().out
    assert "ARW" in table and "[rad/s/sqrt(Hz)]" in table and "[deg/sqrt(h)]" not in table
    assert main([*args, "--output-units", "rad", "--json"]) == 0
    figure = json.loads(capsys.readouterr().out)["units"][0]["axes"]["x"]["figures"]["arw"]
    assert figure["unit"] == "rad/s/sqrt(Hz)"
    assert figure["limit"] == pytest.approx(tool_units.noise_density_rad_s_rt_hz(0.06))
    assert main(["report", str(record_csv), "--profile", profile, "--no-store", "--format",
                 "json", "--out", str(tmp_path), "--output-units", "rad"]) == 0
    written = json.loads(next(tmp_path.glob("*.json")).read_text())
    assert written["units"][0]["axes"]["x"]["figures"]["arw"]["unit"] == "rad/s/sqrt(Hz)"


def test_results_trend_in_rad(record_csv: Path, graded: RunGrade, tmp_path: Path,
                              capsys) -> None:
    db = tmp_path / "results.sqlite"
    assert main(["grade", str(record_csv), "--profile", graded.profile.path, "--db", str(db)]) == 0
    capsys.readouterr()
    assert main(["results", "--db", str(db), "--trend", "arw", "--json"]) == 0
    deg = json.loads(capsys.readouterr().out)
    assert main(["results", "--db", str(db), "--trend", "arw", "--json",
                 "--output-units", "rad"]) == 0
    rad = json.loads(capsys.readouterr().out)
    pairs = _pairs(deg, rad)
    assert len(pairs) >= 4 and rad["points"][0]["unit"] == "rad/s/sqrt(Hz)"
    _assert_exact(pairs)
    assert main(["results", "--db", str(db), "--trend", "arw", "--output-units", "rad"]) == 0
    assert "arw [rad/s/sqrt(Hz)]" in capsys.readouterr().out



def _read_csv(path: Path) -> tuple[list[str], list[list[str]]]:
    with path.open() as fh:
        rows = list(csv.reader(fh))
    return rows[0], rows[1:]


def test_analyze_png_and_csv_in_rad(record_csv: Path, tmp_path: Path, capsys,
                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """``analyze --png/--csv --output-units rad``: the curve is the deg curve (of the same
    analysis) times the deg/h factor under rad-named columns; the figure's axis names rad/s."""
    from station.output import curve_csv, plots

    labels: list[str] = []
    analyses: list = []
    save, write = plots._save, curve_csv.write_curve_csv

    def labelled(fig, path, dpi=None):  # the figure as it is saved
        labels.extend(ax.get_ylabel() for ax in fig.axes)
        return save(fig, path, dpi)

    def kept(axes, path, family):
        analyses.append(axes)
        return write(axes, path, family)

    monkeypatch.setattr(plots, "_save", labelled)
    monkeypatch.setattr(curve_csv, "write_curve_csv", kept)
    rad_csv, png = tmp_path / "rad.csv", tmp_path / "rad.png"
    assert main(["analyze", str(record_csv), "--csv", str(rad_csv), "--png", str(png),
                 "--output-units", "rad"]) == 0
    assert f"curve: {rad_csv}" in capsys.readouterr().out
    assert png.stat().st_size > 10_000
    assert labels == ["overlapping Allan deviation [rad/s]"]
    deg_csv = tmp_path / "deg.csv"
    deg_csv.write_text(curve_csv.curve_table(analyses[0]))  # the deg default
    deg_head, deg_rows = _read_csv(deg_csv)
    rad_head, rad_rows = _read_csv(rad_csv)
    assert deg_head == ["axis", "tau_s", "oadev_deg_h", "oadev_ci_low_deg_h",
                        "oadev_ci_high_deg_h", "n_clusters", "fit_adev_deg_h"]
    assert rad_head == [h.replace("_deg_h", "_rad_s") for h in deg_head]
    assert len(rad_rows) == len(deg_rows) > 20
    factor = RAD_FAMILY.factor("deg/h")
    for d, r in zip(deg_rows, rad_rows, strict=True):
        assert (d[0], d[1], d[5]) == (r[0], r[1], r[5])
        for i in (2, 3, 4, 6):
            if d[i]:
                assert float(r[i]) == pytest.approx(float(d[i]) * factor, rel=1e-13, abs=0.0)
            else:
                assert r[i] == ""


def test_davar_png_in_rad(record_csv: Path, tmp_path: Path, capsys,
                          monkeypatch: pytest.MonkeyPatch) -> None:
    """``davar --png --output-units rad``: the heat map's colours are log10 of the rad/s
    deviations its JSON prints, its colour bars say so."""
    from station.output import plots

    figures = []
    save = plots._save

    def kept(fig, path, dpi=None):
        figures.append(fig)
        return save(fig, path, dpi)

    monkeypatch.setattr(plots, "_save", kept)
    png = tmp_path / "davar.png"
    assert main(["davar", str(record_csv), "--window-s", "200", "--step-s", "100", "--png",
                 str(png), "--output-units", "rad", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert png.stat().st_size > 10_000
    labels = [ax.get_ylabel() for ax in figures[0].axes]
    assert labels.count("log10 ADEV (rad/s)") == 2 and not [x for x in labels if "deg" in x]
    adev = np.array(doc["axes"][0]["adev_rad_s"], dtype=float)  # [window][tau]
    mesh = np.asarray(figures[0].axes[0].collections[0].get_array(), dtype=float)
    np.testing.assert_allclose(mesh.reshape(adev.T.shape), np.log10(adev).T, rtol=1e-12)


def test_gmwm_wavelet_variances_name_their_unit(record_csv: Path, tmp_path: Path, capsys,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """The GMWM's wavelet variances: ``wv_deg2_s2`` (and ``model_wv_``, ``wv_ci_low_``,
    ``wv_ci_high_``) beside the interface's ``wv``...; in rad ``wv_rad2_s2``, times
    (pi/180)^2, the unit-less keys left out; the wavelet figure in (rad/s)^2."""
    from station.output import plots

    labels: list[str] = []
    save = plots._save

    def labelled(fig, path, dpi=None):
        labels.extend(ax.get_ylabel() for ax in fig.axes)
        return save(fig, path, dpi)

    monkeypatch.setattr(plots, "_save", labelled)
    command = ["analyze", str(record_csv), "--axis", "x", "--method", "gmwm", "--model", "wn",
               "--json"]
    assert main(command) == 0
    deg = json.loads(capsys.readouterr().out)["axes"][0]["gmwm"]
    png = tmp_path / "wv.png"
    assert main([*command, "--output-units", "rad", "--png", str(png)]) == 0
    rad = json.loads(capsys.readouterr().out)["axes"][0]["gmwm"]
    assert rad == to_rad_family(deg)
    assert labels == ["Haar wavelet variance [(rad/s)^2]"] and png.stat().st_size > 10_000
    factor = (math.pi / 180) ** 2
    for stem in ("wv", "model_wv", "wv_ci_low", "wv_ci_high"):
        assert deg[stem] == deg[f"{stem}_deg2_s2"] and len(deg[stem]) >= 5
        assert stem not in rad and f"{stem}_deg2_s2" not in rad
        np.testing.assert_allclose(rad[f"{stem}_rad2_s2"], np.array(deg[stem]) * factor,
                                   rtol=1e-13)
    assert rad["wv_tau_s"] == deg["wv_tau_s"] and rad["wv_ci"] == deg["wv_ci"]
    assert set(rad["params"]) == {"wn_rad_s_rt_hz"}


def test_model_curve_in_rad(capsys) -> None:
    """``station model curve --output-units rad``: ``adev_rad_s`` and ``terms_rad_s`` (the
    deg/h curve times its factor), the table in rad/s."""
    command = ["model", "curve", "zhang2015-fog", "--taus", "1,10,100"]
    assert main([*command, "--json"]) == 0
    deg = json.loads(capsys.readouterr().out)
    assert main([*command, "--json", "--output-units", "rad"]) == 0
    rad = json.loads(capsys.readouterr().out)
    assert set(rad) == {"tau_s", "adev_rad_s", "terms_rad_s"}
    factor = RAD_FAMILY.factor("deg/h")
    np.testing.assert_allclose(rad["adev_rad_s"], np.array(deg["adev_deg_h"]) * factor,
                               rtol=1e-13)
    for term, values in deg["terms_deg_h"].items():
        np.testing.assert_allclose(rad["terms_rad_s"][term], np.array(values) * factor,
                                   rtol=1e-13)
    assert main([*command, "--output-units", "rad"]) == 0
    table = capsys.readouterr().out.splitlines()
    assert table[0].endswith("in rad/s") and len(table) == 2 + 3
    assert float(table[2].split()[1]) == pytest.approx(rad["adev_rad_s"][0], rel=1e-4)
