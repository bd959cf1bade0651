"""``results``: the results database: gradings by filter, yield per lot, a figure's trend."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from station.model.kinds import Verdict
from station.output.results import (
    GradingRow,
    LotYield,
    ResultsDatabase,
    TrendPoint,
    default_database_path,
    export_csv,
)
from station.output.results_backends import DatabaseLocation, database_exists


@dataclass(frozen=True)
class ResultsRequest:
    """What to read from the results database.

    Attributes
    ----------
    db : str, Path or None
        The database (None: :func:`default_database_path`).
    show : {"gradings", "yield", "trend"}
        Gradings by filter, yield per lot, or one figure over test dates.
    model, lot, serial : str or None
        Filters (``yield``: the model only; ``trend``: model and lot).
    since, until : str or None
        Test dates, ISO 8601 (``until`` includes its day).
    verdict : {"pass", "fail", "indeterminate"} or None
        Only gradings with this verdict.
    review, latest : bool
        Only gradings flagged for review; only each unit's newest grading.
    figure, axis : str or None
        ``trend``: the profile figure name and, optionally, the axis.
    csv : Path or None
        ``gradings``: also export the rows as CSV here.
    """

    db: DatabaseLocation | None = None
    show: Literal["gradings", "yield", "trend"] = "gradings"
    model: str | None = None
    lot: str | None = None
    serial: str | None = None
    since: str | None = None
    until: str | None = None
    verdict: Verdict | None = None
    review: bool = False
    latest: bool = False
    figure: str | None = None
    axis: str | None = None
    csv: Path | None = None

    @property
    def database(self) -> DatabaseLocation:
        """The database (file or URL) the request names."""
        return self.db or default_database_path()


@dataclass(frozen=True)
class ResultsAnswer:
    """What the database holds for a request (``exists`` False: there is no database yet)."""

    database: DatabaseLocation
    exists: bool = True
    gradings: tuple[GradingRow, ...] = ()
    yields: tuple[LotYield, ...] = ()
    trend: tuple[TrendPoint, ...] = ()
    csv: Path | None = None


def query_results(request: ResultsRequest) -> ResultsAnswer:
    """Read what ``request`` asks for (and export the gradings as CSV when it asks).

    A database that does not exist yet is not created: ``exists`` is False.
    """
    path = request.database
    if not database_exists(path):
        return ResultsAnswer(path, exists=False)
    with ResultsDatabase(path) as db:
        if request.show == "yield":
            return ResultsAnswer(path, yields=tuple(db.yield_by_lot(model=request.model)))
        if request.show == "trend":
            if not request.figure:
                raise ValueError("a trend needs the figure's name")
            points = db.trend(request.figure, model=request.model, axis=request.axis,
                              lot=request.lot)
            return ResultsAnswer(path, trend=tuple(points))
        rows = db.gradings(model=request.model, lot=request.lot, since=request.since,
                           until=request.until, verdict=request.verdict, serial=request.serial,
                           latest=request.latest, review=request.review)
    csv = export_csv(rows, request.csv) if request.csv is not None else None
    return ResultsAnswer(path, gradings=tuple(rows), csv=csv)
