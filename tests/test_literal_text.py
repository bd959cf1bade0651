"""User text that matplotlib would read as math (``$...$``, a lone ``\\frac{``) is drawn as
typed in every sheet, chart and statistics file; a report that fails leaves the file it
would have replaced as it was."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path
from urllib.parse import quote

import pytest
from starlette.testclient import TestClient

from station.cli import main
from station.evaluation.grading import RunGrade
from station.output.report import writer
from station.output.results import ResultsDatabase
from station.storage.atomic_files import replacing
from station.web import ServeConfig, create_app
from tests.test_production_stats import _fill, _unit, graded  # noqa: F401  (a fixture)

SERIAL = r"SN-$\bad{$-1"
LOT = r"L$x_{$"
OPERATOR = r"$\frac{$ ops"
STATION = r"bench-$\sqrt$"


def _odd(graded: RunGrade) -> RunGrade:  # noqa: F811
    """A unit of the line whose serial, lot, operator and station are such text."""
    odd = _unit(graded, 4)
    run = replace(odd.run, metadata=replace(odd.run.metadata, lot=LOT, operator=OPERATOR,
                                            station_host=STATION),
                  start_utc="2026-06-21T08:00:00Z",
                  units=(replace(odd.run.units[0], serial_number=SERIAL),))
    return replace(odd, run=run, units=(replace(odd.units[0], unit=run.units[0]),))


@pytest.fixture(scope="module")
def line(graded: RunGrade, tmp_path_factory) -> tuple[Path, RunGrade]:  # noqa: F811
    location = _fill(str(tmp_path_factory.mktemp("math") / "line.sqlite"), graded)
    odd = _odd(graded)
    with ResultsDatabase(location) as db:
        db.store(odd)
    return Path(location), odd


def _pages(pdf: Path) -> int:
    return len(re.findall(rb"/Type\s*/Page\b", pdf.read_bytes()))


@pytest.mark.slow
def test_statistics_files_and_charts_draw_the_text_as_typed(line, tmp_path: Path) -> None:
    db, _ = line
    pdf, html = tmp_path / "stats.pdf", tmp_path / "stats.html"
    assert main(["results", "--stats", "--db", str(db), "--pdf", str(pdf),
                 "--html", str(html)]) == 0
    assert _pages(pdf) >= 2 and html.read_text().count("data:image/png;base64,") >= 2
    client = TestClient(create_app(ServeConfig(db)))
    for chart in ("trend", "chart"):
        answer = client.get(f"/figures/arw/{chart}.svg")
        assert answer.status_code == 200, answer.text[:300]
        # matplotlib writes each text it draws as a comment beside its glyphs
        assert ("<!-- L$x_{$" if chart == "trend" else "<!-- arw") in answer.text
    assert client.get(f"/units/{quote(SERIAL, safe='')}").status_code == 200


def test_a_sheet_with_such_text_is_written_whole(line, tmp_path: Path) -> None:
    _, odd = line
    for fmt in ("pdf", "html"):
        path = tmp_path / f"sheet.{fmt}"
        path.write_text("an earlier sheet\n")
        assert writer(fmt)(odd, path) == path
        assert path.read_bytes().startswith(b"%PDF" if fmt == "pdf" else b"<!DOCTYPE")
    assert _pages(tmp_path / "sheet.pdf") >= 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sheet.html", "sheet.pdf"]


def test_a_failed_write_leaves_the_earlier_file_as_it_was(tmp_path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.backends.backend_pdf import PdfPages
    from matplotlib.figure import Figure

    good = tmp_path / "sheet.pdf"
    with replacing(good) as tmp, PdfPages(tmp) as pdf:
        for title in ("page 1", "page 2"):
            fig = Figure()
            fig.suptitle(title)
            pdf.savefig(fig)
    before = good.read_bytes()
    assert _pages(good) == 2
    with pytest.raises(ValueError), replacing(good) as tmp, PdfPages(tmp) as pdf:
        first = Figure()
        first.suptitle("page 1 of the new sheet")
        pdf.savefig(first)
        broken = Figure()
        broken.suptitle(r"$\bad{$")  # matplotlib's own parse error, mid-file
        pdf.savefig(broken)
    assert good.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["sheet.pdf"]  # no temporary file left
