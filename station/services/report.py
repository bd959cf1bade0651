"""``report``: spec sheets (PDF, HTML, JSON, CSV) of a graded run, recorded in the results
database."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

from analysis.gmwm.models import GmwmModel
from analysis.units.conversions import DEG_FAMILY, UnitFamily
from station.errors import UsageError
from station.evaluation.gmwm_run import run_with_gmwm
from station.evaluation.grading import RunGrade
from station.model.profiles import Profile
from station.model.sheet_header import load_sheet_header
from station.output.report import ReportFormat, write_report
from station.output.results_backends import DatabaseLocation
from station.output.results_queue import STORE_RETRY_S
from station.services.grade import GradeRequest, grade, store_grading


@dataclass(frozen=True)
class ReportRequest:
    """Which run to grade and which reports to write where.

    ``grade.store`` (default True) also records the grading (once per run, unit and
    profile) and each report file in ``grade.database``. ``header`` is the sheet header
    file (company, logo, station, conditions, approval block:
    :mod:`station.model.sheet_header`), None for none; ``units`` the unit family the sheets
    print their figures in.

    ``method="gmwm"`` adds each unit's GMWM page (the GMWM terms beside the Allan
    read-offs, the wavelet variance with both models' curves) with ``gmwm_model`` (a
    model string or ``"auto"``; None: the profile's ``[test] gmwm_model``, else auto);
    ``"allan"`` leaves it out; None does what the profile's ``gmwm_model`` says.
    """

    grade: GradeRequest
    formats: tuple[ReportFormat, ...] = ("pdf",)
    out_dir: Path = Path(".")
    header: Path | None = None
    units: UnitFamily = DEG_FAMILY
    method: Literal["allan", "gmwm"] | None = None
    gmwm_model: str | None = None


def gmwm_model_of(request: ReportRequest, profile: Profile | None) -> str | None:
    """The GMWM model the sheets carry (a model string or ``"auto"``), None for none
    (``profile`` None: the request's own choice, checked before the run is graded).

    Raises
    ------
    UsageError
        A model with ``method="allan"`` or without a method, or a model that does not parse.
    """
    if request.gmwm_model is not None and request.method != "gmwm":
        raise UsageError("--model goes with --method gmwm")
    if request.method == "allan":
        return None
    model = request.gmwm_model or (profile.gmwm_model if profile is not None else None)
    if request.method == "gmwm" and model is None:
        model = "auto"
    if model is not None and model.strip().lower() != "auto":
        GmwmModel.parse(model)  # a bad model string is bad input
    return model


@dataclass(frozen=True)
class ReportResult:
    """The graded run, the files written (format, path) and the grading's warnings."""

    graded: RunGrade
    files: tuple[tuple[ReportFormat, Path], ...]
    warnings: tuple[str, ...] = ()


def write_reports(graded: RunGrade, formats: tuple[ReportFormat, ...], out_dir: Path,
                  db_path: DatabaseLocation | None, *, retry_s: float = STORE_RETRY_S
                  ) -> tuple[tuple[ReportFormat, Path], ...]:
    """Write each report of ``graded`` into ``out_dir``; with ``db_path``, record the files
    against the unit gradings (storing the grading with them when it is not there yet;
    :func:`store_grading`, which waits up to ``retry_s`` for a database that is away)."""
    files = tuple((fmt, write_report(graded, fmt, out_dir)) for fmt in formats)
    if db_path is not None:
        store_grading(graded, db_path, reports=files, join=True, retry_s=retry_s)
    return files


def report(request: ReportRequest) -> ReportResult:
    """Grade the run as :func:`station.services.grade.grade` does, add the GMWM when asked
    (:func:`gmwm_model_of`) and write its reports.

    Raises
    ------
    UsageError
        A GMWM model without ``method="gmwm"``, or one that does not parse.
    """
    sheet = load_sheet_header(request.header) if request.header is not None else None  # fails first
    gmwm_model_of(request, None)  # a bad --model fails before the run is graded
    graded = grade(request.grade)
    run = replace(graded.graded, sheet=sheet, output_units=request.units)
    model = gmwm_model_of(request, run.profile)
    if model is not None:
        run = run_with_gmwm(run, model)
    db = request.grade.database if request.grade.store else None
    files = write_reports(run, request.formats, request.out_dir, db,
                          retry_s=request.grade.db_retry_s)
    return ReportResult(run, files, graded.warnings)
