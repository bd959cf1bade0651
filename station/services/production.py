"""``results --stats``: the producer's statistics of each model (profile) and lot, as
numbers, and drawn as an HTML page or a PDF (:mod:`station.output.production_stats`); the
models are never pooled."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from station.model.dates import check_date
from station.output.production_stats import StatsByModel, compute_stats_by_model
from station.output.results import ResultsDatabase, default_database_path
from station.output.results_backends import DatabaseLocation, database_exists


@dataclass(frozen=True)
class StatsRequest:
    """Which units' statistics, and where to draw them.

    Attributes
    ----------
    db : str, Path or None
        Results database (None: :func:`default_database_path`).
    model, lot : str or None
        Only units of this model (None: every model, each apart), of this lot.
    since : str or None
        Only units tested from this date (ISO 8601, UTC).
    html, pdf : Path or None
        Write the statistics with their plots as a self-contained HTML page, a PDF.
    """

    db: DatabaseLocation | None = None
    model: str | None = None
    lot: str | None = None
    since: str | None = None
    html: Path | None = None
    pdf: Path | None = None

    @property
    def database(self) -> DatabaseLocation:
        """The database the request names."""
        return self.db if self.db is not None else default_database_path()


@dataclass(frozen=True)
class StatsAnswer:
    """The statistics, one block per model, and the files written (``stats`` None: there is
    no database yet)."""

    database: DatabaseLocation
    stats: StatsByModel | None
    html: Path | None = None
    pdf: Path | None = None


def production_stats(request: StatsRequest) -> StatsAnswer:
    """Read the selected units from the database and compute their statistics, model by
    model; write the HTML page and the PDF when the request names them. A database that
    does not exist yet is not created.

    Raises
    ------
    UsageError
        A ``since`` that is not a date.
    ResultsDatabaseError
        The database cannot be opened.
    """
    check_date("--since", request.since)
    if not database_exists(request.database):
        return StatsAnswer(request.database, None)
    with ResultsDatabase(request.database) as db:
        stats = compute_stats_by_model(db, model=request.model, lot=request.lot,
                                       since=request.since)
    html = pdf = None
    if request.html is not None or request.pdf is not None:
        from station.output.production_pdf import write_stats_pdf
        from station.output.production_report import write_stats_html

        html = write_stats_html(stats, request.html) if request.html is not None else None
        pdf = write_stats_pdf(stats, request.pdf) if request.pdf is not None else None
    return StatsAnswer(request.database, stats, html, pdf)
