"""Spec-sheet reports: PDF pages, HTML and JSON figures, CSV rows, as written to real files."""

from __future__ import annotations

import csv
import json
from dataclasses import replace
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from pypdf import PdfReader

from station.cli import main
from station.errors import UsageError
from station.evaluation.grading import RunGrade, grade_run
from station.model.profiles import load_profile
from station.model.runs import RunEvent, RunInfo, RunMetadata, UnitRun
from station.model.sheet_header import load_sheet_header
from station.output.report import FORMATS, write_report
from station.output.report.common import header_fields, unit_sheet
from station.output.report.json_report import SCHEMA, SCHEMA_VERSION
from station.storage.runs import read_record
from tests.test_grading import make_record, profile_text, write_profile

FIGURES = """
[figures.arw]
unit = "deg/sqrt(h)"
limits = { A = 0.06, B = 0.2 }

[figures.bias_instability]
unit = "deg/h"
limits = { A = 1.0, B = 3.0 }

[figures.rrw]
unit = "deg/h^1.5"
"""


@pytest.fixture(scope="module")
def graded(tmp_path_factory) -> RunGrade:
    """A run of two units (x and y axes each), the second with gaps and a resync in its log."""
    d = tmp_path_factory.mktemp("reports")
    profile = load_profile(
        write_profile(d, profile_text(axes='["x", "y"]', warmup_s=30.0, figures=FIGURES))
    )
    units = []
    for i, serial in enumerate(("SN-1001", "SN-1002")):
        record = read_record(make_record(d / f"u{i}.csv", n=9_000, seed=20 + i, n_axes=2))
        events = () if i == 0 else (
            RunEvent(f"u{i}", "gap", 120.5, missing_samples=40), RunEvent(f"u{i}", "resync", 120.6),
            RunEvent(f"u{i}", "gap", 400.0, missing_samples=3))
        units.append(UnitRun(f"u{i}", "TG-1", serial, record, events=events))
    metadata = RunMetadata(profile="TEST", operator="A. Tester", lot="LOT-7",
                           station_host="bench-3", software_version="0.1.0")
    run = RunInfo(path=str(d / "run-0042.h5"), units=tuple(units), metadata=metadata,
                  start_utc="2026-11-20T08:00:00Z", stop_utc="2026-11-20T08:15:00Z")
    return grade_run(run, profile)


def test_pdf_has_one_page_per_unit(graded: RunGrade, tmp_path: Path) -> None:
    path = write_report(graded, "pdf", tmp_path)
    reader = PdfReader(path)
    pages = _unit_pages(reader)  # notes that do not fit a sheet follow it on a page
    assert len(pages) == 2
    for page, unit in zip(pages, graded.units, strict=True):
        text = page.extract_text()
        assert unit.unit.serial_number in text and f"GRADE {unit.grade.upper()}" in text
        assert "LOT-7" in text and "A. Tester" in text and "bench-3" in text and "TEST@7" in text
        assert "ARW (read-off)" in text and "deg/sqrt(h)" in text
        assert "DAVAR" in text and "Allan deviation" in text
        arw = unit.axis("x").figures[0]
        assert f"{arw.value:.4g}" in text  # the figure itself is printed
        width, height = float(page.mediabox.width), float(page.mediabox.height)
        assert (round(width), round(height)) == (595, 842)  # A4 portrait, points
    record = _record_pages(reader)[1]  # the event log is on the test record, not page 1
    assert "samples missing: 43" in record and "resync 1" in record
    assert "resync" not in pages[1].extract_text()


def test_first_page_is_the_sheet_to_send(graded: RunGrade, tmp_path: Path) -> None:
    """Page 1: header, figures, plots, verdict and a footer naming the test as run; the
    event log, ambiguity and notes on the test record; every page numbered, with the
    sheet's header and footer; the read-off beside the fitted figure marked info."""
    fitted = FIGURES.replace("[figures.bias_instability]", "[figures.bias_instability_fit]")
    fitted += '\n[figures.bias_instability]\nunit = "deg/h"\n'
    profile = load_profile(write_profile(tmp_path, profile_text(
        axes='["x", "y"]', warmup_s=30.0, figures=fitted)))
    unit = graded.units[1]
    events = (*unit.unit.events, RunEvent("u1", "crc_error", 300.0, count=6),
              RunEvent("u1", "timeout", 310.0))
    run = replace(graded.run, units=(replace(unit.unit, events=events),))
    regraded = grade_run(run, profile)
    ambiguous = [line for line in unit_sheet(regraded, regraded.units[0]).analysis
                 if line.startswith("AMBIGUOUS")]
    assert ambiguous  # the short record allows other readings of the rate random walk
    reader = PdfReader(write_report(regraded, "pdf", tmp_path))
    texts = [page.extract_text() for page in reader.pages]
    first, record = texts[0], "\n".join(texts[1:])
    for line in ("crc_error", "resync", "timeout", "samples missing", "AMBIGUOUS", "REVIEW",
                 "Earth rate", "spikes:"):
        assert line not in first, line
        assert line in record, line
    assert "Verdict: grade " in first and "the test record at the end of this sheet" in first
    assert "15 min static test at 10 Hz (warm-up 30 s discarded), profile TEST@7" in first
    n = len(texts)
    for k, text in enumerate(texts, start=1):
        assert f"page {k} of {n}" in text
        assert "Gyro spec sheet: TG-1 s/n SN-1002" in text and "GRADE " in text
        assert "static test at 10 Hz" in text and "generated by gyro-station" in text
    assert "Test record: events, analysis, notes" in texts[-1]
    lines = _table_lines(reader.pages[0])
    # (the visitor sees a ligature apart: "( fi t)", "read-o ff")
    spec = next(t for t in lines if t.startswith("y B bias instability ("))
    info = next(t for t in lines if t.startswith("y bias instability (read-o"))
    assert "not graded" not in spec and ("pass" in spec or "fail" in spec
                                         or "indeterminate" in spec)
    assert "not graded" in info and info.endswith("info")
    assert "info: shown for information, not graded" in first


def _record_pages(reader: PdfReader) -> list[str]:
    """Per unit, the text of its test record (the pages after its last page with
    a figure)."""
    out: list[str] = []
    for page in reader.pages:
        text = page.extract_text()
        if "page 1 of" in text:
            out.append("")
        if "Test record" in text:
            out[-1] += text
    return out


class _FigureTable(HTMLParser):
    """Collects the data-* attributes of the figure rows and the image sources."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[dict[str, str]] = []
        self.images: list[str] = []
        self.sections: list[dict[str, str]] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = {k: v or "" for k, v in attrs}
        if tag == "tr" and "data-figure" in a:
            self.rows.append(a)
        elif tag == "img":
            self.images.append(a["src"])
        elif tag == "section":
            self.sections.append(a)


def test_html_is_self_contained_with_the_figures(graded: RunGrade, tmp_path: Path) -> None:
    path = write_report(graded, "html", tmp_path)
    parser = _FigureTable()
    parser.feed(path.read_text(encoding="utf-8"))
    assert [s["data-grade"] for s in parser.sections] == [u.grade for u in graded.units]
    assert len(parser.images) == 4 and all(
        src.startswith("data:image/png;base64,") for src in parser.images
    )
    assert len(parser.rows) == 2 * 2 * 3  # units x axes x figures
    first = graded.units[0].axis("x")
    row = next(r for r in parser.rows if r["data-axis"] == "x" and r["data-figure"] == "arw")
    arw = first.figures[0]
    assert float(row["data-value"]) == pytest.approx(arw.value)
    assert row["data-verdict"] == arw.verdicts.get(first.deciding_grade, "pass")
    assert {r["data-verdict"] for r in parser.rows if r["data-figure"] == "rrw"} == {"info"}
    assert "http://" not in path.read_text() and "https://" not in path.read_text()
    # page 1's part, then the test record with the event log, each with the test's footer
    second = path.read_text().split('<section class="unit"')[2]
    sheet, record = second.split('<div class="test-record">')
    assert "resync" not in sheet and "resync 1" in record and "samples missing: 43" in record
    assert sheet.count("15 min static test at 10 Hz") == record.count("15 min static test") == 1
    assert "not graded</td><td class=\"verdict\">info" in sheet


def test_json_follows_the_schema(graded: RunGrade, tmp_path: Path) -> None:
    doc = json.loads(write_report(graded, "json", tmp_path).read_text())
    assert doc["schema"] == SCHEMA and doc["schema_version"] == SCHEMA_VERSION
    assert doc["profile"]["name"] == "TEST" and doc["profile"]["rule"] == "guard-banded"
    assert doc["run"]["lot"] == "LOT-7"
    assert [u["serial_number"] for u in doc["units"]] == ["SN-1001", "SN-1002"]
    for unit_doc, unit in zip(doc["units"], graded.units, strict=True):
        assert unit_doc["grade"] == unit.grade
        assert unit_doc["header"]["Operator"] == "A. Tester"
        for axis in unit.axes:
            a = unit_doc["axes"][axis.axis]
            assert a["grade"] == axis.grade
            for f in axis.figures:
                section = a["figures"] if f.spec.graded else a["info"]
                assert section[f.name]["value"] == pytest.approx(f.value)
                assert section[f.name]["ci_low"] == pytest.approx(f.ci_low)
                assert section[f.name]["unit"] == f.spec.unit
            assert a["figures"]["arw"]["verdict"] in ("pass", "fail", "indeterminate")
            assert len(a["allan"]["tau_s"]) == len(a["allan"]["adev_deg_h"]) > 10
            assert "N_deg_rt_h" in a["fit"]
    assert doc["units"][1]["events"] == {
        "has_log": True,
        "counts": {"gap": 2, "resync": 1},
        "gaps": 2,
        "missing_samples": 43,
        "stop_reason": "",
        "interrupted": False,
    }
    doc_text = (Path(__file__).resolve().parents[1] / "docs" / "report-json-schema.md").read_text()
    for key in (
        "schema_version",
        "ci_low",
        "deciding_grade",
        "could_reach",
        "adev_deg_h",
        "missing_samples",
    ):
        assert f"`{key}`" in doc_text, key  # every key the document has is documented


def test_csv_has_one_row_per_unit_and_axis(graded: RunGrade, tmp_path: Path) -> None:
    with write_report(graded, "csv", tmp_path).open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["serial_number"], r["axis"]) for r in rows] == [
        ("SN-1001", "x"), ("SN-1001", "y"), ("SN-1002", "x"), ("SN-1002", "y")]
    y = graded.units[1].axis("y")
    assert float(rows[3]["arw_value"]) == pytest.approx(y.figures[0].value)
    assert rows[3]["arw_unit"] == "deg/sqrt(h)" and rows[3]["rrw_verdict"] == "info"
    assert rows[3]["axis_grade"] == y.grade and rows[3]["unit_grade"] == graded.units[1].grade


def test_report_command_writes_every_format(tmp_path: Path, capsys) -> None:
    record = make_record(tmp_path / "bench.csv", n=6_000, seed=4)
    profile = write_profile(tmp_path, profile_text(warmup_s=10.0, duration_s=600.0))
    out = tmp_path / "out"
    args = [
        "report",
        str(record),
        "--profile",
        str(profile),
        "--out",
        str(out),
        "--no-store",
        "--serial",
        "S9",
    ]
    for fmt in ("pdf", "json"):  # html and csv: written the same way, checked above
        args += ["--format", fmt]
    assert main(args) == 0
    written = capsys.readouterr().out.split()
    assert sorted(Path(p).suffix for p in written) == [".json", ".pdf"]
    assert set(FORMATS) == {"pdf", "html", "json", "csv"}
    pages = PdfReader(out / "bench_TEST.pdf").pages
    assert len(pages) == 2  # the sheet, its test record
    assert "no event log" in pages[1].extract_text()
    assert "no event log" not in pages[0].extract_text()


@pytest.mark.slow
def test_report_of_a_recorded_hdf5_run(tmp_path: Path) -> None:
    """A run the recorder wrote (two simulated CRG20 units, one dropping frames), graded with the
    shipped CRG20 profile and reported: one page per unit, header and events from the file."""
    models = Path(__file__).resolve().parents[1] / "profiles" / "models" / "CRG20.toml"
    # warp 250: the 5 simulated minutes in 1.2 s of wall time (3,000 frames a unit at
    # 2,500 frames/s, a small load for a pseudo-terminal)
    urls = [f"sim+serial://CRG20?model={models}&protocol=stim300&rate=10&warp=250&seed={seed}{extra}"
            for seed, extra in ((1, "&drop=0.002"), (2, ""))]
    argv = ["record", "--duration", "5m", "--out", str(tmp_path / "runs"), "--lot", "LOT-H5",
            "--operator", "recorder-test", "--quiet"]
    for url in urls:
        argv += ["--unit", url]
    assert main(argv) == 0  # in-process: the recorder's units are processes all the same
    run_file = next((tmp_path / "runs").glob("*.h5"))
    out = tmp_path / "out"
    assert (
        main(
            [
                "report",
                str(run_file),
                "--profile",
                "CRG20",
                "--format",
                "pdf",
                "--format",
                "json",
                "--out",
                str(out),
                "--no-store",
            ]
        )
        == 0
    )
    doc = json.loads(next(out.glob("*.json")).read_text())
    assert [u["header"]["Lot"] for u in doc["units"]] == ["LOT-H5", "LOT-H5"]
    assert all(u["serial_number"] and u["events"]["has_log"] for u in doc["units"])
    assert doc["units"][0]["events"]["counts"].get("connect") == 1
    reader = PdfReader(next(out.glob("*.pdf")))
    pages = _unit_pages(reader)
    assert len(pages) == 2
    for page, record, unit in zip(pages, _record_pages(reader), doc["units"], strict=True):
        text = page.extract_text()
        assert unit["serial_number"] in text and "recorder-test" in text
        assert "events: " in record and "events: " not in text


def test_sheet_header_company_logo_station_approval_and_conventions(
    graded: RunGrade, tmp_path: Path, monkeypatch
) -> None:
    import matplotlib.image

    monkeypatch.delenv("STATION_NAME", raising=False)
    matplotlib.image.imsave(tmp_path / "logo.png", np.tile(np.linspace(0, 1, 40), (12, 1)))
    (tmp_path / "sheet.toml").write_text(
        'company = "Gyro Works Ltd."\nstation = "EOL bench 3"\n'
        'logo = "logo.png"\nconditions = "static, granite table"\n'
        'approval = ["Tested by", "Approved by"]\n'
    )
    sheet = load_sheet_header(tmp_path / "sheet.toml")
    headed = replace(graded, sheet=sheet, units=graded.units[:1])
    fields = dict(header_fields(headed, headed.units[0]))
    assert fields["Company"] == "Gyro Works Ltd." and fields["Station"] == "EOL bench 3"
    assert fields["Test date (UTC)"] == "2026-11-20 08:00:00"  # to the second
    assert fields["Software version"].endswith("(recorded with 0.1.0)")
    assert (
        fields["Temperature"].startswith("not recorded")
        and fields["Conditions"] == "static, granite table"
    )
    text = PdfReader(write_report(headed, "pdf", tmp_path)).pages[0].extract_text()
    for expected in (
        "Gyro Works Ltd.",
        "EOL bench 3",
        "Tested by (name, date, signature):",
        "Approved by",
        "0.664 x",
    ):
        assert expected in text, expected
    # without a header: the host name says what it is, a CSV's unknown recording software is not "-"
    bare = replace(
        graded, run=replace(graded.run, metadata=replace(graded.run.metadata, software_version=""))
    )
    fields = dict(header_fields(bare, bare.units[0]))
    assert (
        fields["Station"] == "bench-3 (host name)"
        and "recorded with" not in fields["Software version"]
    )
    monkeypatch.setenv("STATION_NAME", "line 2")
    assert dict(header_fields(bare, bare.units[0]))["Station"] == "line 2"
    (tmp_path / "bad.toml").write_text('aproval = ["Tested by"]\n')
    with pytest.raises(UsageError, match="unknown key 'aproval'"):
        load_sheet_header(tmp_path / "bad.toml")


def _unit_pages(reader: PdfReader) -> list:
    """The first page of each unit's sheet in a spec-sheet PDF."""
    return [page for page in reader.pages if "page 1 of" in page.extract_text()]


def _text_rows(page) -> list[tuple[float, str]]:
    """(y in points from the bottom, text) of each text run pypdf finds on ``page``."""
    rows: list[tuple[float, str]] = []

    def visit(text, cm, tm, font, size) -> None:
        if text.strip():
            rows.append((tm[5] * cm[3] + cm[5], text.strip()))

    page.extract_text(visitor_text=visit)
    return rows


def _table_lines(page) -> list[str]:
    """The text runs of ``page`` joined into lines (a table's row: its cells, left to
    right)."""
    runs: dict[float, list[tuple[float, str]]] = {}

    def visit(text, cm, tm, font, size) -> None:
        if text.strip():
            y = round(tm[5] * cm[3] + cm[5], 0)
            runs.setdefault(y, []).append((tm[4] * cm[0] + cm[4], text.strip()))

    page.extract_text(visitor_text=visit)
    return [" ".join(t for _, t in sorted(cells)) for _, cells in sorted(runs.items())]


def test_many_notes_continue_the_test_record_above_the_footer(graded: RunGrade,
                                                              tmp_path: Path) -> None:
    many = tuple(f"note number {i}: " + "a long remark on the run " * 8 for i in range(60))
    unit = replace(graded.units[0], notes=graded.units[0].notes + many)
    path = write_report(replace(graded, units=(unit,)), "pdf", tmp_path)
    reader = PdfReader(path)
    assert len(reader.pages) == 3  # the sheet, the test record and its continuation
    assert "note number" not in reader.pages[0].extract_text()
    assert "Test record (continued)" in reader.pages[2].extract_text()
    for k, page in enumerate(reader.pages, start=1):
        rows = _text_rows(page)
        footer = max(y for y, t in rows if "static test at" in t)
        body = [y for y, t in rows if t.startswith(("note number", "a long"))]
        assert not body or min(body) > footer + 6.5  # a whole line of 6.5 pt clears the footer
        assert f"page {k} of 3" in page.extract_text()
    assert "note number 59" in reader.pages[2].extract_text()
