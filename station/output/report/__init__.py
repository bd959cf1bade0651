"""Spec-sheet reports of a graded run: PDF, HTML, JSON and CSV.

:func:`write_report` writes one file per run into a directory: ``<run>_<profile>.pdf``
(one page per unit), ``.html`` (a section per unit, images embedded), ``.json`` (schema in
docs/report-json-schema.md) or ``.csv`` (one row per unit and axis).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Literal, get_args

if TYPE_CHECKING:
    from station.evaluation.grading import RunGrade

ReportFormat = Literal["pdf", "html", "json", "csv"]
FORMATS: tuple[ReportFormat, ...] = get_args(ReportFormat)


def writer(fmt: str) -> Callable[[RunGrade, Path], Path]:
    """The function writing format ``fmt`` (imported on demand: matplotlib is slow to
    import), whole or not at all: into a temporary file moved over the report only when
    complete, so that a failure leaves an earlier report as it was
    (:func:`station.storage.atomic_files.replacing`).

    Raises
    ------
    ValueError
        For an unknown format.
    """
    write = _writer(fmt)

    def write_whole(graded: RunGrade, path: Path) -> Path:
        from station.storage.atomic_files import replacing

        with replacing(path) as tmp:
            write(graded, tmp)
        return Path(path)

    return write_whole


def _writer(fmt: str) -> Callable[[RunGrade, Path], Path]:
    if fmt == "pdf":
        from station.output.report.pdf import write_pdf

        return write_pdf
    if fmt == "html":
        from station.output.report.html import write_html

        return write_html
    if fmt == "json":
        from station.output.report.json_report import write_json

        return write_json
    if fmt == "csv":
        from station.output.report.csv_report import write_csv

        return write_csv
    raise ValueError(f"unknown report format {fmt!r}; use one of {', '.join(FORMATS)}")


def write_report(graded: RunGrade, fmt: str, out_dir: str | Path) -> Path:
    """Write the report of ``graded`` in format ``fmt`` into ``out_dir`` (created); returns the
    file.

    Raises
    ------
    ValueError
        For an unknown format.
    """
    from station.output.report.common import report_stem

    write = writer(fmt)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return write(graded, out / f"{report_stem(graded)}.{fmt}")
