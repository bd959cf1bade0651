"""The line's view of the results database, read-only: yield per model and lot with its
interval, a figure's capability, control chart, run rules and trend over lots (model by
model, never pooled), a unit's grading history and its spec sheet (what ``station serve``
shows, :mod:`station.web`).

Every document here is built from the numbers ``station results`` prints: a figure's
statistics are :meth:`ProductionStats.as_json`'s, the gradings :class:`GradingRow`'s
fields, so a page and ``station results --stats --json`` agree.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager, suppress
from dataclasses import asdict, dataclass
from html import escape
from pathlib import Path

from scipy import stats as scipy_stats

from station.errors import ProfileError, RecordFormatError, ResultsDatabaseError, UsageError
from station.evaluation.run_rules import run_rule_flags
from station.model.dates import check_date
from station.output.production_stats import FigureStats, StatsByModel, compute_stats_by_model
from station.output.results import GradingRow, ResultsDatabase, default_database_path
from station.output.results_backends import DatabaseLocation, redacted

#: How many of the newest gradings the overview lists.
LATEST_GRADINGS = 20
#: Two-sided level of a lot's yield interval (Wilson score interval).
YIELD_CONFIDENCE = 0.95


class DatabaseUnavailableError(ResultsDatabaseError):
    """The results database cannot be read now (a file not there, a server away)."""


@dataclass(frozen=True)
class LineFilter:
    """Which gradings a page shows.

    Attributes
    ----------
    db : str, Path or None
        The results database (None: :func:`default_database_path`).
    since, until : str or None
        Test dates, ISO 8601 (``until`` includes its day).
    model, lot, station, operator : str or None
        Only units of this model, this lot; only runs recorded at this station, by this
        operator.
    """

    db: DatabaseLocation | None = None
    since: str | None = None
    until: str | None = None
    model: str | None = None
    lot: str | None = None
    station: str | None = None
    operator: str | None = None

    @property
    def database(self) -> DatabaseLocation:
        """The database the filter reads."""
        return self.db if self.db is not None else default_database_path()

    def check(self) -> None:
        """Refuse a date that is not one (``2026-13-45`` included).

        Raises
        ------
        UsageError
            ``since`` or ``until`` is not an ISO 8601 date or time.
        """
        check_date("since", self.since)
        check_date("until", self.until)


@contextmanager
def _open(where: LineFilter) -> Iterator[ResultsDatabase]:
    """The database for a ``with`` block, read-only (a database file not there yet, or
    empty, reads as empty and stays so); :class:`DatabaseUnavailableError` saying why when
    it cannot be opened or stops answering inside the block."""
    where.check()
    try:
        db = ResultsDatabase(where.database, read_only=True)
    except ResultsDatabaseError as exc:
        raise DatabaseUnavailableError(str(exc)) from exc
    try:
        yield db
    except db.errors as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise DatabaseUnavailableError(f"the results database {db.name} stopped answering: "
                                       f"{first}") from exc
    finally:
        with suppress(*db.errors):
            db.close()


def yield_interval(passed: int, total: int) -> tuple[float, float] | None:
    """The Wilson score interval of a yield ``passed / total`` at :data:`YIELD_CONFIDENCE`
    (None for no units)."""
    if total <= 0:
        return None
    ci = scipy_stats.binomtest(passed, total).proportion_ci(YIELD_CONFIDENCE, method="wilson")
    return (float(ci.low), float(ci.high))


def line_overview(where: LineFilter) -> dict[str, object]:
    """Per model and lot, the latest grading of each unit the filter selects: units, pass,
    fail, indeterminate, yield and its interval, grade counts; the newest gradings; the
    names to filter by.

    Returns
    -------
    dict
        ``{"database", "filters", "lots": [{"model", "lot", "total", "passed", "failed",
        "indeterminate", "yield", "yield_ci", "grades"}], "gradings": [GradingRow fields,
        newest first], "models", "stations", "operators"}``.

    Raises
    ------
    DatabaseUnavailableError
        The database cannot be read.
    """
    with _open(where) as db:
        rows = db.gradings(model=where.model, lot=where.lot, since=where.since,
                           until=where.until, station=where.station, operator=where.operator,
                           latest=True)
        names = db.distinct_names()
    lots: dict[tuple[str, str], list[GradingRow]] = {}
    for r in rows:
        lots.setdefault((r.model, r.lot), []).append(r)
    table = []
    for (model, lot), members in sorted(lots.items()):
        passed = sum(r.verdict == "pass" for r in members)
        grades: dict[str, int] = {}
        for r in members:
            grades[r.grade] = grades.get(r.grade, 0) + 1
        ci = yield_interval(passed, len(members))
        table.append({"model": model, "lot": lot, "total": len(members), "passed": passed,
                      "failed": sum(r.verdict == "fail" for r in members),
                      "indeterminate": sum(r.verdict == "indeterminate" for r in members),
                      "yield": passed / len(members), "yield_ci": list(ci) if ci else None,
                      "grades": grades})
    newest = sorted(rows, key=lambda r: (r.test_date, r.id), reverse=True)[:LATEST_GRADINGS]
    return {"database": redacted(where.database), "filters": _filters_json(where),
            "lots": table, "gradings": [asdict(r) for r in newest], **names}


def _filters_json(where: LineFilter) -> dict[str, str | None]:
    return {"since": where.since, "until": where.until, "model": where.model, "lot": where.lot,
            "station": where.station, "operator": where.operator}


def line_state(where: LineFilter) -> tuple[int, ...]:
    """The database's state (:meth:`ResultsDatabase.state`): every document and chart of
    the filter is the same while this is.

    Raises
    ------
    DatabaseUnavailableError
        The database cannot be read.
    """
    with _open(where) as db:
        return db.state()


def line_stats(where: LineFilter) -> StatsByModel:
    """``station results --stats`` of the filter's model, lot and first test date: a block
    per model (the filter's model alone when it names one).

    Raises
    ------
    DatabaseUnavailableError
        The database cannot be read.
    """
    with _open(where) as db:
        return compute_stats_by_model(db, model=where.model, lot=where.lot, since=where.since)


def figure_by_model(stats: StatsByModel, name: str) -> dict[str, FigureStats]:
    """Graded figure ``name`` of each model that grades it (model -> its statistics).

    Raises
    ------
    LookupError
        No selected model grades a figure of that name (the message lists theirs).
    """
    found = {m: s.figures[name] for m, s in stats.models.items() if name in s.figures}
    if not found:
        theirs = sorted({f for s in stats.models.values() for f in s.figures})
        raise LookupError(f"no graded figure {name!r} among the selected units; theirs: "
                          f"{', '.join(theirs) or 'none'}")
    return found


def one_model_figure(stats: StatsByModel, name: str) -> FigureStats:
    """Graded figure ``name`` of the one model that grades it among the selected units (a
    chart is drawn of one model's units, never of several pooled).

    Raises
    ------
    LookupError
        No selected model grades it.
    UsageError
        Several do: the request must name the model (``?model=``).
    """
    found = figure_by_model(stats, name)
    if len(found) > 1:
        raise UsageError(f"{name} is graded for several models ({', '.join(found)}): give "
                         "model=MODEL")
    return next(iter(found.values()))


def figure_models_json(stats: StatsByModel, name: str) -> dict[str, object]:
    """Figure ``name`` as ``/api/figures/NAME`` gives it: with the filter's model, that
    model's :func:`figure_json`; without, ``{"name", "models": {model: figure_json}}``
    (each model's values, control chart and run rules apart).

    Raises
    ------
    LookupError
        No selected model grades it.
    """
    found = figure_by_model(stats, name)
    if stats.model is not None:
        return figure_json(found[stats.model])
    return {"name": name, "models": {m: figure_json(f) for m, f in found.items()}}


def figure_json(f: FigureStats) -> dict[str, object]:
    """A figure's statistics (:meth:`FigureStats.as_json`, the keys of ``results --stats
    --json``) with its values in test order (``values``: ``{"serial_number", "lot", "axis",
    "test_date", "value", "unit"}``), the run rules each flags (``run_rules``: rule -> indexes into
    ``values``) and its trend over lots (``lots``: ``{"lot", "n", "mean", "min", "max"}`` in
    the order the lots were first tested; values in ``unit``)."""
    k = f.chart
    values = [v.value if v.value is not None else float("nan") for v in f.values]
    lots: dict[str, list[float]] = {}
    for v in f.values:
        if v.value is not None:
            lots.setdefault(v.lot, []).append(v.value)
    return {
        **f.as_json(),
        "name": f.name,
        "values": [{"serial_number": v.serial_number, "lot": v.lot, "axis": v.axis,
                    "test_date": v.test_date, "value": v.value, "unit": f.unit}
                   for v in f.values],
        "run_rules": {rule: list(i) for rule, i in
                      run_rule_flags(values, k.center, k.sigma).items()},
        "lots": [{"lot": lot, "n": len(xs), "mean": sum(xs) / len(xs), "min": min(xs),
                  "max": max(xs), "unit": f.unit} for lot, xs in lots.items()],
    }


@dataclass(frozen=True)
class UnitHistory:
    """Every stored grading of one serial number, oldest first, with each one's figures
    (``{"axis", "name", "unit", "value", "ci_low", "ci_high", "limit", "verdict"}``) and
    report files (``{"format", "path"}``)."""

    serial_number: str
    gradings: tuple[GradingRow, ...]
    figures: dict[int, tuple[dict[str, object], ...]]
    reports: dict[int, tuple[dict[str, str], ...]]

    def as_json(self) -> dict[str, object]:
        """``{"serial_number", "gradings": [GradingRow fields + "figures", "reports"]}``."""
        return {"serial_number": self.serial_number,
                "gradings": [asdict(g) | {"figures": list(self.figures[g.id]),
                                          "reports": list(self.reports[g.id])}
                             for g in self.gradings]}


def unit_history(where: LineFilter, serial: str) -> UnitHistory:
    """The gradings of unit ``serial`` (of the filter's model, when it names one).

    Raises
    ------
    DatabaseUnavailableError
        The database cannot be read.
    """
    with _open(where) as db:
        rows = tuple(db.gradings(serial=serial, model=where.model))
        figures = {g.id: tuple({"axis": f["axis"], "name": f["name"], "unit": f["unit"],
                                "value": f["value"], "ci_low": f["ci_low"],
                                "ci_high": f["ci_high"], "limit": f["limit_value"],
                                "verdict": f["verdict"]} for f in db.figures(g.id))
                   for g in rows}
        reports = {g.id: tuple({"format": str(r["format"]), "path": str(r["path"])}
                               for r in db.reports(g.id)) for g in rows}
    return UnitHistory(serial, rows, figures, reports)


def unit_of_sheet(html: str, run_unit: str) -> str:
    """The page of one unit of a run's HTML spec sheets (a section per unit,
    :func:`station.output.report.html.write_html`): its head and that unit's section; the
    whole page when it has no section of that unit."""
    start = html.find(f'<section class="unit" id="unit-{escape(run_unit)}"')
    body = html.find("<body>")
    if start < 0 or body < 0:
        return html
    end = html.find("</section>", start)
    if end < 0:
        return html
    return f"{html[:body]}<body>\n{html[start:end + len('</section>')]}\n</body></html>\n"


def unit_sheet_html(where: LineFilter, grading: GradingRow,
                    reports: tuple[dict[str, str], ...]) -> str:
    """The HTML spec sheet of one grading, as the station renders it: the HTML report
    recorded for it (``station report --format html``) when its file is there, else the
    unit's section of the sheet rendered afresh from its run file and the stored profile.

    Raises
    ------
    DatabaseUnavailableError
        The database cannot be read.
    UsageError
        Neither a recorded HTML report nor the run file is there (the message says which
        file is missing).
    """
    for r in reversed(reports):
        if r["format"] == "html" and Path(r["path"]).is_file():
            return unit_of_sheet(Path(r["path"]).read_text(encoding="utf-8"), grading.run_unit)
    from station.evaluation.grading import grade_run
    from station.model.profiles import parse_profile
    from station.output.report.html import CSS, unit_section
    from station.storage.runs import open_run

    with _open(where) as db:
        ref, text = db.profile_text(grading.id)
    if not Path(grading.run_path).is_file():
        raise UsageError(f"no spec sheet: the run file {grading.run_path} is not there and no "
                         "HTML report was recorded (station report --format html --db ...)")
    if not text:
        raise UsageError(f"no spec sheet: the profile {ref} was not stored with the grading")
    try:
        profile = parse_profile(text, path=ref)
        graded = grade_run(open_run(grading.run_path), profile, units=(grading.run_unit,))
    except (ProfileError, RecordFormatError) as exc:
        raise UsageError(f"no spec sheet: {exc}") from exc
    body = "\n".join(unit_section(graded, u) for u in graded.units)
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><style>{CSS}'
            f"</style></head>\n<body>\n{body}\n</body></html>\n")
