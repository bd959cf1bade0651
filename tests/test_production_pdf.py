"""The production statistics PDF laid out as a report: its text (extracted with pypdf) holds
the numbers ``station results --stats --json`` prints, in tables with a title block and
correct plurals; its charts are the yield per lot and each figure against its limits."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from pypdf import PdfReader

from station.cli import main
from station.output.production_pdf import figure_page, summary_page
from station.output.production_stats import compute_stats
from station.output.report.common import fmt
from station.output.results import ResultsDatabase
from tests.test_production_stats import graded, line_file  # noqa: F401 - the line's gradings


def _words(text: str) -> str:
    return re.sub(r"\s+", " ", text)


def test_stats_pdf_tables_hold_the_json_numbers(line_file: str, tmp_path: Path,  # noqa: F811
                                                capsys) -> None:
    pdf = tmp_path / "stats.pdf"
    assert main(["results", "--stats", "--db", line_file, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)["models"]["TG-1"]  # the line's one model
    assert main(["results", "--stats", "--db", line_file, "--pdf", str(pdf)]) == 0
    capsys.readouterr()
    pages = PdfReader(pdf).pages
    assert len(pages) == 1 + len(doc["figures"])
    first = _words(pages[0].extract_text())
    assert "Production statistics" in first and "model TG-1, all lots: 12 units" in first
    assert "Units flagged for review: 1 unit" in first and "1 units" not in first
    for grade, share in doc["yield"].items():  # yield per grade: units and share
        n = doc["grades"][grade]
        assert f"{grade} {n} {100 * share:.1f} %" in first
    for lot, counts in doc["lots"].items():  # yield per lot: units, per grade, sold share
        cells = [str(sum(counts.values())), *(str(counts.get(g, 0)) for g in doc["grades"]),
                 f"{100 * doc['lot_yield'][lot]:.1f} %"]
        assert f"{lot} {' '.join(cells)}" in first
    assert doc["lot_yield"] == {"L1": pytest.approx(1.0), "L2": pytest.approx(5 / 6)}
    for name, f in doc["figures"].items():  # capability: n, mean, std, limit, Ppk
        row = f"{name} {f['unit']} {f['n']} {fmt(f['mean'])} {fmt(f['std'])} {fmt(f['limit'])} "
        assert row + fmt(f["cpk"], 3) in first
    assert doc["review"][0]["serial_number"] in first
    arw = doc["figures"]["arw"]
    page = _words(next(p.extract_text() for p in pages[1:] if "arw [" in p.extract_text()))
    assert f"mean {fmt(arw['mean'])}" in page and f"values {arw['n']}" in page
    assert f"A {fmt(arw['limits'][0])}, B {fmt(arw['limits'][1])}" in page
    assert "control chart" in page and "limit A = " in page


def test_stats_pdf_charts(line_file: str) -> None:  # noqa: F811
    with ResultsDatabase(line_file) as db:
        stats = compute_stats(db)
    page = summary_page(stats)
    chart = next(ax for ax in page.axes if ax.get_title().startswith("yield per lot"))
    bars = [(p.get_x(), p.get_height()) for p in chart.patches]
    assert sum(h for _, h in bars) == stats.units  # every unit in a lot's bar
    assert [t.get_text() for t in chart.texts] == ["100 %", "83 %"]
    arw = figure_page(stats, stats.figures["arw"])
    hist = next(ax for ax in arw.axes if ax.get_xlabel().startswith("arw"))
    limits = sorted(line.get_xdata()[0] for line in hist.get_lines()
                    if line.get_label().startswith("limit"))
    assert limits == list(stats.figures["arw"].limits.values())
