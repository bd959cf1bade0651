"""Capability per model: a results database holding two models (simulated VG951 and CRG20
runs, graded with their shipped profiles through the services layer) gives one block of
statistics per model, never pooled: ``station results --stats`` as text, JSON, HTML and
PDF, and ``station serve``'s overview, figure pages, charts and ``/api`` documents; every
number of ``/api/stats?units=rad`` is converted."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import pytest
from pypdf import PdfReader
from starlette.testclient import TestClient

from station.cli import main
from station.services.grade import GradeRequest, RunSource, grade, store_grading
from station.services.simulate import SimulateRequest, simulate_run
from station.web import ServeConfig, create_app

MODELS = ("VG951", "CRG20")
#: Units per model; graded alternately, so the two models are interleaved in test order.
UNITS = 3
#: Keys of a figure's statistics: in the figure's unit, dimensionless (every key is one).
IN_UNIT = {"mean", "std", "limits", "limit", "center", "ucl", "lcl", "fitted_median",
           "fitted_p99865"}
PLAIN = {"cp", "cpk", "cpu", "cpk_ci", "cpk_fitted", "cpk_fitted_ci", "fitted_distribution",
         "limit_grades", "n", "above_limit"}
#: rad-family unit and factor of each deg-family unit (1 deg = pi/180 rad, 1 h = 3600 s,
#: sqrt(h) = 60 sqrt(s)).
RAD = {"deg/h": ("rad/s", math.pi / 180 / 3600),
       "deg/sqrt(h)": ("rad/s/sqrt(Hz)", math.pi / 180 / 60)}


@pytest.fixture(scope="module")
def two_models(tmp_path_factory: pytest.TempPathFactory) -> str:
    """An SQLite database of three 10-minute VG951 runs and three CRG20 runs (lots L1, L2),
    each graded with its model's profile and stored."""
    d = tmp_path_factory.mktemp("two_models")
    db = str(d / "line.sqlite")
    for i in range(UNITS):
        for model in MODELS:
            run = d / f"{model}-{i}.h5"
            simulate_run(SimulateRequest(run, model=model, duration_s=600.0, seed=20 + i))
            graded = grade(GradeRequest(RunSource(run, serial=f"{model}-{i}", lot=f"L{i % 2 + 1}"),
                                        profile=model)).graded
            store_grading(graded, db)
    return db


def _json(capsys: pytest.CaptureFixture[str], *args: str) -> dict[str, Any]:
    assert main(["results", *args]) == 0
    return json.loads(capsys.readouterr().out)


def _trend(capsys: pytest.CaptureFixture[str], db: str, figure: str, model: str) -> list[float]:
    return [p["value"] for p in _json(capsys, "--db", db, "--trend", figure, "--model", model,
                                      "--json")["points"]]


def assert_figures_in_rad(deg: dict[str, Any], rad: dict[str, Any]) -> None:
    """``rad`` is ``deg`` (one model's statistics) with every number in a figure's unit
    converted, every other number as it is."""
    assert set(rad) == set(deg)
    assert {k: v for k, v in rad.items() if k != "figures"} == {
        k: v for k, v in deg.items() if k != "figures"}
    for name, f in deg["figures"].items():
        r = rad["figures"][name]
        assert set(f) == IN_UNIT | PLAIN | {"unit", "out_of_control"}, "a key not classed"
        unit, factor = RAD[f["unit"]]
        assert r["unit"] == unit and set(r) == set(f)
        for key in IN_UNIT:
            if isinstance(f[key], list):
                assert r[key] == pytest.approx([v * factor for v in f[key]], rel=1e-12), key
            else:
                assert r[key] == (None if f[key] is None
                                  else pytest.approx(f[key] * factor, rel=1e-12)), key
        assert {k: r[k] for k in PLAIN} == {k: f[k] for k in PLAIN}
        assert [p["value"] for p in r["out_of_control"]] == pytest.approx(
            [p["value"] * factor for p in f["out_of_control"]], rel=1e-12)


def test_stats_json_has_a_block_per_model(two_models: str,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(capsys, "--stats", "--db", two_models, "--json")
    assert doc["units"] == 2 * UNITS and doc["model"] is None
    assert set(doc["models"]) == set(MODELS)
    for model, block in doc["models"].items():
        assert block["model"] == model and block["units"] == UNITS
        assert block["profile"] == f"{model}@1"  # its own profile, not the last graded one
        assert set(block["lots"]) == {"L1", "L2"} and set(block["lot_yield"]) == {"L1", "L2"}
        assert sum(sum(c.values()) for c in block["lots"].values()) == UNITS
        bias = block["figures"]["bias"]
        values = _trend(capsys, two_models, "bias", model)
        assert bias["n"] == UNITS and bias["mean"] == pytest.approx(sum(values) / UNITS)
        assert bias["limits"] == {"VG951": [1.0, 3.0], "CRG20": [50.0, 150.0]}[model]
    # each model against its own limits: CRG20's bias is two orders above VG951's
    assert doc["models"]["CRG20"]["figures"]["bias"]["mean"] > 10 * doc["models"]["VG951"][
        "figures"]["bias"]["mean"]
    one = _json(capsys, "--stats", "--db", two_models, "--model", "VG951", "--json")
    assert one == doc["models"]["VG951"]  # --model: the single-model document, as before
    assert {"units", "yield", "figures", "grades", "review", "profile", "lots",
            "lot_yield"} <= set(one)
    rad = _json(capsys, "--stats", "--db", two_models, "--json", "--output-units", "rad")
    for model in MODELS:
        assert_figures_in_rad(doc["models"][model], rad["models"][model])
    empty = _json(capsys, "--stats", "--db", str(Path(two_models).with_name("none.sqlite")),
                  "--json")
    assert (empty["exists"], empty["units"], empty["models"]) == (False, 0, {})


def test_stats_text_html_and_pdf_per_model(two_models: str, tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(capsys, "--stats", "--db", two_models, "--json")
    html, pdf = tmp_path / "stats.html", tmp_path / "stats.pdf"
    assert main(["results", "--stats", "--db", two_models, "--html", str(html),
                 "--pdf", str(pdf)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("6 units of 2 models (latest grading each): CRG20, VG951")
    for model in MODELS:
        block = text.split(f"== model {model} ==\n", 1)[1].split("== model", 1)[0]
        assert block.startswith(f"3 units (latest grading each), profile {model}@1")
        mean = doc["models"][model]["figures"]["bias"]["mean"]
        assert re.search(rf"^bias +deg/h +3 +{mean:.4g} ", block, re.M)
    assert main(["results", "--stats", "--db", two_models, "--model", "CRG20"]) == 0
    single = capsys.readouterr().out
    assert single.startswith("3 units (latest grading each), profile CRG20@1")
    assert "== model" not in single
    page = html.read_text()
    assert re.findall(r"<section class='model' data-model='(\w+)'>", page) == ["CRG20", "VG951"]
    figures = sum(len(b["figures"]) for b in doc["models"].values())
    assert page.count("data:image/png;base64,") == figures
    pages = [re.sub(r"\s+", " ", p.extract_text()) for p in PdfReader(pdf).pages]
    assert len(pages) == 2 + figures  # per model: its summary, then a page per figure
    for model in MODELS:
        summary = [p for p in pages if f"model {model}, all lots: 3 units" in p]
        assert len(summary) == 1 + len(doc["models"][model]["figures"])
        assert f"profile {model}@1" in summary[0]


def _section(page: str, model: str) -> str:
    return page.split(f'<section class="model" data-model="{model}">', 1)[1].split(
        "</section>", 1)[0]


def test_web_pages_per_model(two_models: str, capsys: pytest.CaptureFixture[str]) -> None:
    client = TestClient(create_app(ServeConfig(two_models)))
    doc = _json(capsys, "--stats", "--db", two_models, "--json")
    assert client.get("/api/stats").json() == doc  # key for key, a block per model
    rad = client.get("/api/stats", params={"units": "rad"}).json()
    for model in MODELS:
        assert_figures_in_rad(doc["models"][model], rad["models"][model])
    assert client.get("/api/stats", params={"model": "CRG20"}).json() == doc["models"]["CRG20"]
    overview = client.get("/").text
    for model in MODELS:
        section = _section(overview, model)
        assert f"{model}: 3 units, profile {model}@1" in section
        bias = doc["models"][model]["figures"]["bias"]
        row = section.split('<tr data-figure="bias">', 1)[1].split("</tr>", 1)[0]
        assert f"/figures/bias?model={model}" in row
        assert [float(v) for v in re.findall(r'data-value="([^"]+)"', row)][:3] == [
            bias["mean"], bias["std"], bias["limit"]]
    # a figure page without ?model=: a section per model, each its own chart and run rules
    figure = client.get("/api/figures/bias").json()
    assert figure["name"] == "bias" and set(figure["models"]) == set(MODELS)
    for model, f in figure["models"].items():
        stats = doc["models"][model]["figures"]["bias"]
        assert {k: f[k] for k in stats} == stats
        assert {v["serial_number"] for v in f["values"]} == {f"{model}-{i}" for i in range(UNITS)}
        assert all(i < UNITS for flagged in f["run_rules"].values() for i in flagged)
        assert client.get("/api/figures/bias", params={"model": model}).json() == f
    page = client.get("/figures/bias")
    assert page.status_code == 200
    for model in MODELS:
        section = _section(page.text, model)
        assert f"chart.svg?model={model}" in section and f"trend.svg?model={model}" in section
        assert 'class="run-rules"' in section
    # a chart is of one model: naming none of two is refused, naming one draws it
    assert client.get("/figures/bias/chart.svg").status_code == 400
    assert client.get("/figures/bias/trend.svg").status_code == 400
    chart = client.get("/figures/bias/chart.svg", params={"model": "VG951"})
    assert chart.status_code == 200 and "<svg" in chart.text
    assert "<svg" in client.get("/figures/bias/trend.svg", params={"model": "CRG20"}).text
    assert client.get("/api/figures/nothing").status_code == 404
