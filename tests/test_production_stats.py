"""The producer's statistics (``station results --stats``): Cp/Cpk and the individuals chart
against numbers worked by hand, then yield, capability, control chart and review over a
results database on SQLite and on PostgreSQL, as JSON, HTML and PDF."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from station.cli import main
from station.evaluation.capability import capability, individuals_chart
from station.evaluation.grading import RunGrade, grade_run
from station.model.profiles import load_profile
from station.output.results import ResultsDatabase
from station.storage.runs import open_run
from tests.test_grading import make_record, profile_text, write_profile

#: arw (deg/sqrt(h)) of twelve units in test order; the ninth is far off the others.
ARW = [0.050, 0.052, 0.049, 0.051, 0.053, 0.050, 0.048, 0.052, 0.150, 0.051, 0.049, 0.050]
GRADES = ["A"] * 8 + ["B", "A", "A", "indeterminate"]


def test_capability_worked_by_hand() -> None:
    c = capability([1.0, 2.0, 3.0, 4.0, 5.0, float("nan")], 10.0)
    std = math.sqrt(2.5)  # sum of squares 10 over 4 degrees of freedom
    assert (c.n, c.mean, c.std) == (5, 3.0, pytest.approx(std))
    # an upper limit only: Cpu (= Cpk), no Cp against the natural bound 0
    assert c.cp is None and c.cpk == pytest.approx(7.0 / (3 * std)) and c.cpu == c.cpk
    assert c.above_limit == 0.0
    half = 1.959964 * math.sqrt(1 / 45 + c.cpk**2 / 8)  # the normal approximation's interval
    assert c.cpk_ci == (pytest.approx(c.cpk - half), pytest.approx(c.cpk + half))
    both = capability([1.0, 2.0, 3.0, 4.0, 5.0], 10.0, 0.5)
    assert both.cp == pytest.approx(9.5 / (6 * std)) and both.cpl == pytest.approx(2.5 / (3 * std))
    assert both.cpk == both.cpl and both.cpk is not None and both.cpk <= both.cp
    assert both.fitted is not None and both.fitted.cpk is not None and both.fitted.cp is not None
    assert both.fitted.cpk <= both.fitted.cp
    assert capability([2.0, 2.0], 1.0).cpk is None and capability([2.0], 1.0).std is None
    # individuals chart: moving ranges 1, 1, 1, 16, 15 -> mean 6.8, sigma 6.8 / 1.128
    k = individuals_chart([1.0, 2.0, 3.0, 4.0, 20.0, 5.0])
    assert k.center == pytest.approx(35.0 / 6) and k.sigma == pytest.approx(6.8 / 1.128)
    assert k.ucl == pytest.approx(35.0 / 6 + 3 * 6.8 / 1.128) and k.out_of_control == ()
    steady = individuals_chart([1.0, 1.1, 0.9, 1.0, 1.05, 0.95, 3.0, 1.0, 1.1, 0.9])
    assert steady.out_of_control == (6,)
    assert individuals_chart([0.1 + 0.2] * 5 + [0.3]).out_of_control == ()  # no variation


@pytest.fixture(scope="module")
def graded(tmp_path_factory) -> RunGrade:
    d = tmp_path_factory.mktemp("stats")
    record = make_record(d / "unit.csv", n=6_000, seed=5)
    text = profile_text(warmup_s=10.0, duration_s=600.0)  # the record's 10 min
    return grade_run(open_run(record), load_profile(write_profile(d, text)))


def _unit(graded: RunGrade, i: int) -> RunGrade:
    """The grading as unit ``i`` of the line: its serial, lot, date, grade and arw."""
    unit = graded.units[0]
    axis = unit.axes[0]
    figures = tuple(replace(f, value=ARW[i]) if f.name == "arw" else f for f in axis.figures)
    run = replace(
        graded.run,
        metadata=replace(graded.run.metadata, lot="L1" if i < 6 else "L2"),
        start_utc=f"2026-06-{i + 1:02d}T08:00:00Z",
        units=(replace(unit.unit, serial_number=f"S{i:02d}"),),
    )
    return replace(
        graded,
        run=run,
        units=(
            replace(
                unit,
                unit=run.units[0],
                grade=GRADES[i],
                axes=(replace(axis, figures=figures, review=()),),
            ),
        ),
    )


def _fill(location: str, graded: RunGrade) -> str:
    with ResultsDatabase(location) as db:
        for i in range(len(ARW)):
            db.store(_unit(graded, i))
        db.store(_unit(graded, 0))  # S00's grading stored again: one row (idempotent store)
    return location


@pytest.fixture(params=["sqlite", "postgresql"])
def line_db(request, graded: RunGrade, tmp_path: Path) -> str:
    """The line's gradings on each back end."""
    location = (
        str(tmp_path / "line.sqlite")
        if request.param == "sqlite"
        else request.getfixturevalue("postgres_url")
    )
    return _fill(location, graded)


@pytest.fixture()
def line_file(graded: RunGrade, tmp_path: Path) -> str:
    """The line's gradings in an SQLite file (what does not depend on the back end)."""
    return _fill(str(tmp_path / "line.sqlite"), graded)


def _stats(capsys, *args: str) -> dict:
    assert main(["results", "--stats", *args, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_stats_of_a_line(line_db: str, capsys) -> None:
    out = _stats(capsys, "--model", "TG-1", "--db", line_db)
    assert out["units"] == 12
    assert out["yield"] == pytest.approx({"A": 10 / 12, "B": 1 / 12, "indeterminate": 1 / 12})
    arw = out["figures"]["arw"]
    assert arw["limits"] == [0.06, 0.2] and arw["limit"] == 0.2
    mean, std = float(np.mean(ARW)), float(np.std(ARW, ddof=1))
    assert (arw["mean"], arw["std"]) == (pytest.approx(mean), pytest.approx(std))
    assert arw["cp"] is None and arw["cpk"] == pytest.approx((0.2 - mean) / (3 * std))
    assert arw["cpu"] == arw["cpk"] and arw["cpk_ci"][0] < arw["cpk"] < arw["cpk_ci"][1]
    assert arw["fitted_distribution"] in ("lognormal", "gamma")
    assert arw["cpk_fitted"] == pytest.approx(
        (0.2 - arw["fitted_median"]) / (arw["fitted_p99865"] - arw["fitted_median"]))
    assert [p["serial_number"] for p in arw["out_of_control"]] == ["S08"]
    assert set(out["figures"]) == {"arw", "bias_instability"}  # the graded figures only
    assert [u["serial_number"] for u in out["review"]] == ["S08"]
    assert "out of control" in out["review"][0]["reasons"][0]
    assert _stats(capsys, "--lot", "L2", "--db", line_db)["units"] == 6
    assert _stats(capsys, "--since", "2026-06-11", "--db", line_db)["units"] == 2
    assert _stats(capsys, "--model", "other", "--db", line_db)["units"] == 0


def test_stats_drawn_as_html_and_pdf(line_file: str, tmp_path: Path, capsys) -> None:
    line_db = line_file
    html, pdf = tmp_path / "stats.html", tmp_path / "stats.pdf"
    assert (
        main(["results", "--stats", "--db", line_db, "--html", str(html), "--pdf", str(pdf)]) == 0
    )
    text = capsys.readouterr().out
    assert "arw" in text and "1 unit flagged for review" in text and "S08" in text
    page = html.read_text()
    assert page.count("data:image/png;base64,") == 2 and "data-figure='arw'" in page
    from pypdf import PdfReader

    assert len(PdfReader(pdf).pages) == 3  # the summary, then a page per graded figure
    assert main(["results", "--db", line_db, "--html", str(html)]) == 2  # --html needs --stats


def test_every_listing_takes_json(line_file: str, capsys) -> None:
    line_db = line_file
    assert main(["results", "--db", line_db, "--lot", "L1", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["gradings"]
    assert len(rows) == 6 and rows[0]["serial_number"] == "S00" and rows[0]["grade"] == "A"
    assert main(["results", "--db", line_db, "--yield", "--json"]) == 0
    lots = {y["lot"]: y for y in json.loads(capsys.readouterr().out)["yield"]}
    assert (lots["L1"]["total"], lots["L2"]["yield"]) == (6, pytest.approx(5 / 6))
    assert main(["results", "--db", line_db, "--trend", "arw", "--json"]) == 0
    points = json.loads(capsys.readouterr().out)["points"]
    assert [p["value"] for p in points] == list(ARW)  # S00 stored twice: one point


def test_fitted_capability_of_skewed_values_uses_the_fitted_percentiles() -> None:
    """Chi-square values (a noise figure's spread): gamma fitted by maximum likelihood as
    scipy fits it, the index from its percentiles, a bootstrap interval that holds it and
    is the same on a second call (fixed seed)."""
    from scipy import stats

    from station.evaluation.capability import fitted_capability

    x = stats.chi2.rvs(9, size=80, random_state=np.random.default_rng(5)) / 9 * 0.1
    f = fitted_capability(x, 0.2)
    assert f is not None and f.cpk is not None and f.cpk_ci is not None
    fits = {"gamma": stats.gamma.fit(x, floc=0), "lognormal": stats.lognorm.fit(x, floc=0)}
    dist = (stats.gamma(fits["gamma"][0], scale=fits["gamma"][2]) if f.distribution == "gamma"
            else stats.lognorm(fits["lognormal"][0], scale=fits["lognormal"][2]))
    assert f.median == pytest.approx(dist.median(), rel=1e-4)
    assert f.p99865 == pytest.approx(dist.ppf(0.99865), rel=1e-4)
    assert f.cpk == pytest.approx((0.2 - f.median) / (f.p99865 - f.median))
    assert f.cpk_ci[0] < f.cpk < f.cpk_ci[1] and fitted_capability(x, 0.2) == f
    assert fitted_capability(np.r_[x, 0.0], 0.2) is None  # a value at the bound: no fit
