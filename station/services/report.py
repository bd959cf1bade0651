"""``report``: spec sheets (PDF, HTML, JSON, CSV) of a graded run, recorded in the results
database."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from analysis.units import DEG_FAMILY, UnitFamily
from station.evaluation.grading import RunGrade
from station.model.sheet_header import load_sheet_header
from station.output.report import ReportFormat, write_report
from station.output.results import ResultsDatabase
from station.output.results_backends import DatabaseLocation
from station.services.grade import GradeRequest, grade, store_grading


@dataclass(frozen=True)
class ReportRequest:
    """Which run to grade and which reports to write where.

    ``grade.store`` (default True) also records the grading (once per run, unit and
    profile) and each report file in ``grade.database``. ``header`` is the sheet header
    file (company, logo, station, conditions, approval block:
    :mod:`station.model.sheet_header`), None for none; ``units`` the unit family the sheets
    print their figures in.
    """

    grade: GradeRequest
    formats: tuple[ReportFormat, ...] = ("pdf",)
    out_dir: Path = Path(".")
    header: Path | None = None
    units: UnitFamily = DEG_FAMILY


@dataclass(frozen=True)
class ReportResult:
    """The graded run, the files written (format, path) and the grading's warnings."""

    graded: RunGrade
    files: tuple[tuple[ReportFormat, Path], ...]
    warnings: tuple[str, ...] = ()


def write_reports(graded: RunGrade, formats: tuple[ReportFormat, ...], out_dir: Path,
                  db_path: DatabaseLocation | None) -> tuple[tuple[ReportFormat, Path], ...]:
    """Write each report of ``graded`` into ``out_dir``; with ``db_path``, record the files
    against the unit gradings (storing the grading first when it is not there yet)."""
    files = tuple((fmt, write_report(graded, fmt, out_dir)) for fmt in formats)
    if db_path is not None:
        ids = store_grading(graded, db_path, again=False)
        with ResultsDatabase(db_path) as db:
            for grading_id in ids:
                for fmt, path in files:
                    db.add_report(grading_id, fmt, path)
    return files


def report(request: ReportRequest) -> ReportResult:
    """Grade the run as :func:`station.services.grade.grade` does and write its reports."""
    sheet = load_sheet_header(request.header) if request.header is not None else None  # fails first
    graded = grade(request.grade)
    run = replace(graded.graded, sheet=sheet, output_units=request.units)
    db = request.grade.database if request.grade.store else None
    files = write_reports(run, request.formats, request.out_dir, db)
    return ReportResult(run, files, graded.warnings)
