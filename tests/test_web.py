"""``station serve``'s pages and JSON through Starlette's test client, over a results
database filled by real gradings (the line of tests/test_production_stats.py: twelve units
in two lots, one out of control), and real run files under ``--runs``."""

from __future__ import annotations

import itertools
import json
import re
import threading
from dataclasses import replace
from pathlib import Path
from urllib.parse import quote

import pytest
from starlette.testclient import TestClient

from station.cli import main
from station.evaluation.grading import RunGrade
from station.output.report.html import write_html
from station.output.results import ResultsDatabase
from station.web import ServeConfig, create_app
from tests.test_capability_per_model import assert_figures_in_rad
from tests.test_production_stats import _fill, _unit, graded  # noqa: F401  (a fixture)

#: A serial number with markup, graded like any other unit.
SCRIPT_SERIAL = "<script>alert('x')</script>"
TOKEN = "line-token-0123456789abcdef"


def _line(graded: RunGrade, directory: Path) -> Path:  # noqa: F811
    """The line's database, plus a unit with markup in its serial and lot whose HTML spec
    sheet was recorded, run at station "bench-2" by "ops <b>"."""
    location = _fill(str(directory / "line.sqlite"), graded)
    odd = _unit(graded, 3)
    odd = replace(odd, run=replace(odd.run, metadata=replace(
        odd.run.metadata, lot="L3<i>", operator="ops <b>", station_host="bench-2"),
        start_utc="2026-06-20T08:00:00Z",
        units=(replace(odd.run.units[0], serial_number=SCRIPT_SERIAL),)))
    odd = replace(odd, units=(replace(odd.units[0], unit=odd.run.units[0]),))
    # the run's sheets, recorded with the grading: a section per unit, another unit first
    other = replace(odd.units[0], unit=replace(odd.run.units[0], unit_id="unit0",
                                               serial_number="OTHER-1"))
    sheet = write_html(replace(odd, units=(other, *odd.units)), directory / "odd.html")
    with ResultsDatabase(location) as db:
        db.store(odd)
        (row,) = db.gradings(serial=SCRIPT_SERIAL)
        db.add_report(row.id, "html", sheet)
    return Path(location)


@pytest.fixture(scope="module")
def line(graded: RunGrade, tmp_path_factory) -> Path:  # noqa: F811
    return _line(graded, tmp_path_factory.mktemp("web"))


@pytest.fixture(scope="module")
def client(line: Path) -> TestClient:
    return TestClient(create_app(ServeConfig(line)))


def _cli_json(capsys, *args: str) -> dict:
    assert main(list(args)) == 0
    return json.loads(capsys.readouterr().out)


def _values(page: str, css_class: str) -> list[float]:
    """The exact values (``data-value``) of a table's numeric cells, in order."""
    table = page.split(f'<table class="{css_class}">', 1)[1].split("</table>", 1)[0]
    return [float(v) for v in re.findall(r'data-value="([^"]+)"', table)]


def test_pages_show_the_numbers_of_results_stats(client: TestClient, line: Path,
                                                 capsys) -> None:
    cli = _cli_json(capsys, "results", "--stats", "--json", "--db", str(line), "--model", "TG-1")
    api = client.get("/api/stats", params={"model": "TG-1"}).json()
    assert api == cli  # key for key, value for value
    rad = _cli_json(capsys, "results", "--stats", "--json", "--db", str(line), "--model", "TG-1",
                    "--output-units", "rad")
    assert client.get("/api/stats", params={"model": "TG-1", "units": "rad"}).json() == rad
    arw = cli["figures"]["arw"]
    assert arw["fitted_median"] is not None and arw["fitted_p99865"] is not None
    assert_figures_in_rad(cli, rad)  # every number in a figure's unit converted, fitted too
    page = client.get("/", params={"model": "TG-1"}).text
    row = page.split('<tr data-figure="arw">', 1)[1].split("</tr>", 1)[0]
    shown = [float(v) for v in re.findall(r'data-value="([^"]+)"', row)]
    assert shown == [arw["mean"], arw["std"], arw["limit"], arw["cpk"], arw["cpk_fitted"]]
    figure = client.get("/figures/arw", params={"model": "TG-1"})
    assert figure.status_code == 200
    assert _values(figure.text, "capability")[:5] == [arw["mean"], arw["std"], arw["cpu"],
                                                      arw["cpk"], arw["cpk_fitted"]]
    doc = client.get("/api/figures/arw", params={"model": "TG-1"}).json()
    assert {k: doc[k] for k in arw} == arw and len(doc["values"]) == arw["n"]
    flagged = doc["run_rules"]["beyond_3_sigma"]
    assert [doc["values"][i]["serial_number"] for i in flagged] == ["S08"]
    assert [lot["lot"] for lot in doc["lots"]] == ["L1", "L2", "L3<i>"]
    in_rad = client.get("/api/figures/arw", params={"model": "TG-1", "units": "rad"}).json()
    factor = rad["figures"]["arw"]["mean"] / arw["mean"]
    assert in_rad["values"][0]["value"] == pytest.approx(doc["values"][0]["value"] * factor)
    assert in_rad["lots"][0]["max"] == pytest.approx(doc["lots"][0]["max"] * factor)
    chart = client.get("/figures/arw/chart.svg", params={"model": "TG-1"})
    assert chart.headers["content-type"] == "image/svg+xml" and "<svg" in chart.text
    assert "<svg" in client.get("/figures/arw/trend.svg").text
    rad_page = client.get("/", params={"model": "TG-1", "units": "rad"}).text
    rad_row = rad_page.split('<tr data-figure="arw">', 1)[1].split("</tr>", 1)[0]
    assert float(re.findall(r'data-value="([^"]+)"', rad_row)[0]) == rad["figures"]["arw"]["mean"]
    assert client.get("/", params={"units": "furlong"}).status_code == 400
    assert client.get("/api/stats", params={"since": "yesterday"}).status_code == 400
    overview = client.get("/api/overview").json()
    yields = _cli_json(capsys, "results", "--yield", "--json", "--db", str(line))["yield"]
    assert {(r["lot"], r["total"], r["passed"]) for r in overview["lots"]} == {
        (y["lot"], y["total"], y["passed"]) for y in yields}
    l2 = next(r for r in overview["lots"] if r["lot"] == "L2")
    assert l2["yield"] == next(y["yield"] for y in yields if y["lot"] == "L2")
    assert l2["yield_ci"][0] < l2["yield"] < l2["yield_ci"][1]
    whole = client.get("/").text  # the charts: inline SVG, drawn from the same numbers
    chart = whole.split('<svg class="chart yield-chart"', 1)[1].split("</svg>", 1)[0]
    assert chart.count('<g class="lot"') == len(overview["lots"])
    low, high = (100 * v for v in l2["yield_ci"])
    assert (f'data-lot="L2"><title>TG-1 L2 (n={l2["total"]}): yield {100 * l2["yield"]:.1f} %, '
            f"95 % interval [{low:.1f}, {high:.1f}] %</title>") in chart
    models = re.findall(r'<section class="model" data-model="([^"]+)">', whole)
    assert models and whole.count('<svg class="chart capability-chart"') == len(models)
    ppk = whole.split('<svg class="chart capability-chart"', 1)[1].split("</svg>", 1)[0]
    assert f'data-figure="arw"><title>arw: Ppk {arw["cpk"]:.3g}' in ppk
    assert client.get("/api/overview", params={"station": "bench-2"}).json()["lots"][0][
        "total"] == 1
    assert client.get("/api/overview", params={"until": "2026-06-03"}).json()["lots"][0][
        "total"] == 3


def test_markup_in_a_serial_lot_or_operator_is_shown_as_text(client: TestClient) -> None:
    page = client.get("/").text
    assert "&lt;script&gt;alert(&#x27;x&#x27;)&lt;/script&gt;" in page
    assert "<script>alert" not in page and "L3<i>" not in page and "ops <b>" not in page
    assert "L3&lt;i&gt;" in page and "ops &lt;b&gt;" in page  # the operator filter's choice
    unit = client.get(f"/units/{quote(SCRIPT_SERIAL, safe='')}")
    assert unit.status_code == 200 and "<script>alert" not in unit.text
    assert client.get(f"/api/units/{quote(SCRIPT_SERIAL, safe='')}").json()[
        "serial_number"] == SCRIPT_SERIAL
    link = re.search(r'id="sheet-link"', unit.text)
    assert link and 'sandbox src="/sheets/' in unit.text
    sheet_url = re.search(r'href="(/sheets/[^"]+)"', unit.text)
    assert sheet_url is not None
    sheet = client.get(sheet_url.group(1).replace("&amp;", "&"))
    # the sheet the station rendered, shown in a sandbox that runs no script
    assert sheet.status_code == 200 and 'class="figures"' in sheet.text
    assert sheet.text.count('<section class="unit"') == 1 and "OTHER-1" not in sheet.text
    assert "&lt;script&gt;" in sheet.text  # this unit's section, its serial escaped
    assert "default-src 'none'" in sheet.headers["content-security-policy"]
    # a sheet not rendered yet is said to be rendering (static/sheet.js drops the note once
    # the frame has loaded); one the server keeps is shown at once
    assert 'id="sheet-rendering"' in unit.text and '"/static/sheet.js"' in unit.text
    again = client.get(f"/units/{quote(SCRIPT_SERIAL, safe='')}").text
    assert 'id="sheet-rendering"' not in again
    assert "sheet-rendering" in client.get("/static/sheet.js").text
    assert client.get("/static/nothing.js").status_code == 404
    assert client.get("/units/nobody").status_code == 404


def test_no_endpoint_writes_and_a_token_guards_an_open_host(line: Path, tmp_path: Path,
                                                            capsys) -> None:
    open_app = TestClient(create_app(ServeConfig(line)))
    for path in ("/", "/api/stats", "/runs"):
        assert open_app.post(path).status_code == 405 and open_app.delete(path).status_code == 405
    guarded = TestClient(create_app(ServeConfig(line, token=TOKEN)))
    assert guarded.get("/api/stats").status_code == 401 and guarded.get("/").status_code == 401
    assert guarded.get("/", headers={"Authorization": "Bearer wrong"}).status_code == 401
    assert guarded.get("/api/stats", headers={"Authorization": f"Bearer {TOKEN}"}).status_code \
        == 200
    first = guarded.get("/", params={"token": TOKEN})
    assert first.status_code == 200 and "station_token" in first.headers["set-cookie"]
    assert guarded.get("/api/overview").status_code == 200  # the cookie carries it now
    # the command: an open host without a token is refused (exit 2, one line)
    assert main(["serve", "--db", str(line), "--host", "0.0.0.0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--token-file" in err[0]
    short = tmp_path / "token"
    short.write_text("short\n")
    assert main(["serve", "--host", "0.0.0.0", "--token-file", str(short)]) == 2


def test_database_gone_is_a_page_that_retries(tmp_path: Path) -> None:
    for location in (str(tmp_path / "gone" / "results.sqlite"),
                     "postgresql://station@127.0.0.1:1/results"):
        app = TestClient(create_app(ServeConfig(location)))
        page = app.get("/")
        assert page.status_code == 503 and 'http-equiv="refresh"' in page.text
        assert 'id="unavailable"' in page.text
        answer = app.get("/api/stats")
        assert answer.status_code == 503 and "error" in answer.json()


def test_an_empty_or_new_database_is_served_empty_and_left_as_it_was(tmp_path: Path) -> None:
    empty, new = tmp_path / "empty.sqlite", tmp_path / "new.sqlite"
    empty.write_bytes(b"")
    for location in (empty, new):
        client = TestClient(create_app(ServeConfig(location)))
        assert client.get("/api/overview").json()["lots"] == []
        assert client.get("/api/stats").json()["units"] == 0
        assert client.get("/").status_code == 200
        assert client.get("/figures/arw/chart.svg").status_code == 404
    assert empty.read_bytes() == b"" and not new.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty.sqlite"]


def test_charts_are_drawn_once_per_database_state(graded: RunGrade,  # noqa: F811
                                                  tmp_path: Path) -> None:
    location = _fill(str(tmp_path / "line.sqlite"), graded)
    app = create_app(ServeConfig(location))
    client = TestClient(app)
    answers: list[tuple[int, str]] = []

    def ask() -> None:
        answer = client.get("/figures/arw/chart.svg")
        answers.append((answer.status_code, answer.text))

    threads = [threading.Thread(target=ask) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert {status for status, _ in answers} == {200} and len({t for _, t in answers}) == 1
    assert app.state.render_cache.computed == 2  # the statistics once, the chart once
    assert client.get("/api/figures/arw").status_code == 200
    assert app.state.render_cache.computed == 2  # the statistics kept
    with ResultsDatabase(location) as db:  # a new grading: a new state, drawn again
        db.store(replace(_unit(graded, 5), run=replace(_unit(graded, 5).run,
                                                       path="another-run.h5")))
    assert client.get("/figures/arw/chart.svg").status_code == 200
    assert app.state.render_cache.computed == 4


def test_a_bad_token_of_any_kind_is_401_and_a_bad_date_400(line: Path) -> None:
    guarded = TestClient(create_app(ServeConfig(line, token=TOKEN)))
    for bad in ("jeton-\u00e9t\u00e9-0123456789", "\u6e2c\u8a66", TOKEN + "\u00ff"):
        assert guarded.get("/api/stats", params={"token": bad}).status_code == 401
        cookie = f"station_token={bad}".encode()
        assert guarded.get("/api/stats", headers={"Cookie": cookie}).status_code == 401
        bearer = f"Bearer {bad}".encode()
        assert guarded.get("/api/stats", headers={"Authorization": bearer}).status_code == 401
    # a header carries Latin-1: a byte above 127 in it
    answer = guarded.get("/", headers={"Authorization": "Bearer caf\u00e9".encode("latin-1")})
    assert answer.status_code == 401
    client = TestClient(create_app(ServeConfig(line)))
    for since in ("2026-13-45", "2026-02-30", "yesterday"):
        answer = client.get("/api/overview", params={"since": since})
        assert answer.status_code == 400 and since in answer.json()["error"]
    assert client.get("/api/overview", params={"since": "2026-06-02"}).status_code == 200


def test_a_damaged_run_file_is_listed_with_the_rest(line: Path, tmp_path: Path,
                                                    capsys) -> None:
    runs = tmp_path / "runs"
    runs.mkdir()
    assert main(["simulate", "--model", "VG951", "--duration", "120s", "--axes", "3", "--seed", "2",
                 "--quiet",
                 "--out", str(runs / "good.h5")]) == 0
    (runs / "broken.h5").write_bytes(b"not an HDF5 file" * 64)
    client = TestClient(create_app(ServeConfig(line, (runs,))))
    doc = client.get("/api/runs").json()
    assert [Path(r["run"]).name for r in doc["runs"]] == ["good.h5"]
    (damaged,) = doc["damaged"]
    assert Path(damaged["run"]).name == "broken.h5" and damaged["reason"]
    unit = doc["runs"][0]["units"][0]
    assert unit["samples_recorded"] == 1200
    curve = doc["runs"][0]["allan"][0]
    assert len(curve["tau_s"]) > 3 and len(curve["adev_deg_h"]) == 3
    assert (unit["model"], unit["progress"], unit["time_left_s"]) == ("VG951", 1.0, 0.0)
    assert unit["serial_number"] and doc["runs"][0]["duration_requested_s"] == 120.0
    page = client.get("/runs").text
    assert "broken.h5" in page
    assert 'data-field="samples_recorded" data-format="number">1200<' in page
    # a stopped run is listed apart from those being recorded, its times as h:mm:ss
    assert page.index("Recording now") < page.index("No run is being recorded") < page.index(
        "Finished, or recorder gone") < page.index('data-phase="finished"')
    assert f'data-field="serial_number" data-format="text">{unit["serial_number"]}<' in page
    assert 'data-field="progress" data-format="percent">100 %<' in page
    assert 'data-field="t_s" data-format="clock">2:00<' in page  # 119.9 s, to the second
    assert 'data-field="time_left_s" data-format="countdown">0:00<' in page
    assert not re.search(r"\d\.\d{4,}", page.split("</style>")[1])  # no raw float anywhere
    assert '<script src="/static/live.js"' in page
    assert "fetch(\"/api/runs\"" in client.get("/static/live.js").text


def test_api_has_an_index_and_every_api_error_is_json(line: Path) -> None:
    client = TestClient(create_app(ServeConfig(line)))
    index = client.get("/api").json()
    paths = [entry["path"] for entry in index["api"]]
    assert {"/api/overview", "/api/stats", "/api/runs", "/api/units/{serial}"} <= set(paths)
    for answer, status in ((client.get("/api/units/NOPE"), 404),
                           (client.get("/api/no-such-document"), 404),
                           (client.get("/api/stats", params={"units": "grad"}), 400),
                           (client.post("/api/stats"), 405)):
        assert answer.status_code == status
        assert answer.headers["content-type"] == "application/json", answer.text
        assert answer.json()["error"]
    guarded = TestClient(create_app(ServeConfig(line, token="s3cret")))
    answer = guarded.get("/api")
    assert answer.status_code == 401 and "access token" in answer.json()["error"]
    assert guarded.get("/").headers["content-type"].startswith("text/html")
    assert client.get("/no-such-page").headers["content-type"].startswith("text/html")


def test_the_units_switch_marks_the_family_shown(line: Path) -> None:
    client = TestClient(create_app(ServeConfig(line)))
    for shown, other in (("deg", "rad"), ("rad", "deg")):
        page = client.get("/runs", params={"units": shown}).text
        switch = page.split('<span class="units">')[1].split("</span>")[0]
        assert f'<b class="active" aria-current="true">{shown}</b>' in switch
        assert f"units={other}\">{other}</a>" in switch and f">{shown}</a>" not in switch


def test_the_line_on_postgresql(graded: RunGrade, postgres_url: str,  # noqa: F811
                                capsys) -> None:
    location = _fill(postgres_url, graded)
    client = TestClient(create_app(ServeConfig(location)))
    cli = _cli_json(capsys, "results", "--stats", "--json", "--db", location, "--lot", "L2")
    assert client.get("/api/stats", params={"lot": "L2"}).json() == cli
    page = client.get("/", params={"lot": "L2"})
    assert page.status_code == 200 and 'data-serial="S08"' in page.text
    assert client.get("/figures/arw", params={"lot": "L2"}).status_code == 200


def test_run_rules_worked_by_hand() -> None:
    """Centre 0, sigma 1: each rule on a pattern made for it, and not on one a value short."""
    from station.evaluation.run_rules import run_rule_flags

    x = [0.0, 3.5, 0.0, 2.5, -0.5, 2.2, 0.0, 1.5, 1.2, -0.3, 1.1, 1.4]
    flags = run_rule_flags(x, 0.0, 1.0)
    assert flags["beyond_3_sigma"] == (1,)
    assert flags["2_of_3_beyond_2_sigma"] == (3, 5)  # 2.5 after 3.5; 2.2 after 2.5
    assert flags["4_of_5_beyond_1_sigma"] == (11,)  # 1.5 1.2 -0.3 1.1 1.4: one short before
    assert flags["8_on_one_side"] == ()
    drift = [0.1, 0.3, 0.2, 0.4, 0.1, 0.2, 0.5, 0.3, -0.2]
    assert run_rule_flags(drift, 0.0, 1.0)["8_on_one_side"] == (7,)
    assert run_rule_flags(drift[:7], 0.0, 1.0)["8_on_one_side"] == ()
    assert set(run_rule_flags([float("nan")] * 9, 0.0, 1.0).values()) == {()}
    assert run_rule_flags(x, None, None)["beyond_3_sigma"] == ()


def test_capability_chart_places_every_ppk_and_histogram_bars_show() -> None:
    """Ppk from below 0 to 97 on one log axis: each dot between the edges, the one off the
    axis at its edge with ``<`` written; a figure without Ppk said so. Five values 0.1 %
    apart, limits far off: bars of 1/60 of the axis, not 1e-5 of it."""
    from station.output.production_report import MIN_BAR_SHARE, histogram_edges
    from station.web.charts import capability_chart

    doc = {"model": "M<1>", "figures": {
        "arw": {"cpk": 97.2, "cpk_ci": [59.8, 135.0], "n": 14},
        "bias": {"cpk": 1.1, "cpk_ci": [0.7, 1.5], "n": 14},
        "drift": {"cpk": -0.5, "cpk_ci": None, "n": 3},
        "noise": {"cpk": None, "cpk_ci": None, "n": 2}}}
    svg = capability_chart(doc)
    assert "M&lt;1&gt;" in svg and "<1>" not in svg
    dots = {name: float(x) for name, x in re.findall(
        r'data-figure="([^"]+)">.*?<circle cx="([-\d.]+)"', svg)}
    left, right = 190, 760 - 70
    assert set(dots) == {"arw", "bias", "drift"}
    assert all(left <= x <= right for x in dots.values())
    assert dots["drift"] == left < dots["bias"] < dots["arw"] < right
    assert "&lt;-0.5" in svg and "no Ppk" in svg
    values = [1.0, 1.001, 1.002, 1.0005, 1.0015]
    edges = histogram_edges(values, [10.0, 0.0, None])
    assert edges[0] <= min(values) and edges[-1] >= max(values)
    assert min(b - a for a, b in itertools.pairwise(edges)) >= 10.0 * MIN_BAR_SHARE - 1e-12
