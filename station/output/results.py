"""The results database: every graded unit, its figures, verdicts and report files, in SQLite.

One SQLite file holds a station's history (default :func:`default_database_path`, or the
path in ``$STATION_RESULTS_DB``); a ``postgresql://`` URL there or in ``--db`` names a
PostgreSQL server instead, with the same schema and migrations, that a line of stations
writes at once (:mod:`station.results_backends`). Tables::

    schema_migrations (version, applied_utc)     which migrations ran
    profiles   (name, version, sha256, rule, confidence, grades, text)   one row per profile file
    runs       (path, start_utc, stop_utc, operator, lot, station, software_version)
    units      (model, serial_number)                                   one row per gyro
    gradings   (run, unit, profile, graded_utc, test_date, lot, grade, verdict, notes, review,
                revision)   one per run, unit in the run and profile file (or its revisions)
    axis_grades(grading, axis, grade, deciding_grade, n_samples, sample_rate_hz, review)
    figures    (grading, axis, name, unit, value, ci_low, ci_high, limit, verdict)
               (a test sequence's figures too, with axis '': they are the unit's)
    reports    (grading, format, path, created_utc)

Robustness: every write is one transaction (a station killed mid-write leaves the database
as it was before that grading); SQLite's journal is WAL with a busy timeout, so several
stations can write the same file at once; rows two stations may add at once (a profile, a
run, a unit) are inserted with ``ON CONFLICT DO NOTHING``, and a transaction the server
aborts (deadlock) is tried again. Migrations are numbered, run in order inside a
transaction that keeps other stations out, and recorded in ``schema_migrations`` (and
SQLite's ``PRAGMA user_version``).
"""

from __future__ import annotations

import csv
import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from station.errors import ResultsDatabaseError, UsageError
from station.model.kinds import Verdict
from station.output.results_backends import (
    DB_ENV,
    WRITE_ATTEMPTS,
    Backend,
    DatabaseLocation,
    DatabaseLocationError,
    SqliteBackend,
    check_database_file,
    database_location,
    is_database_url,
    open_backend,
    redacted,
)
from station.output.results_store import UNIT_AXIS, ReportFile, add_report, now_utc, store_run
from station.storage.atomic_files import replacing

if TYPE_CHECKING:  # grading pulls in the analysis stack; the browser and the TUI need not
    from station.evaluation.grading import RunGrade

__all__ = ["UNIT_AXIS", "ResultsDatabase", "GradingRow", "LotYield", "TrendPoint", "FigureValue",
           "default_database_path", "export_csv"]

SCHEMA_MIGRATIONS_TABLE = ("CREATE TABLE IF NOT EXISTS schema_migrations "
                           "(version INTEGER PRIMARY KEY, applied_utc TEXT NOT NULL)")
#: Numbered migrations; index + 1 is the schema version each brings the database to.
MIGRATIONS: tuple[str, ...] = (
    # 1: the first schema
    """
    CREATE TABLE profiles (
        id INTEGER PRIMARY KEY, name TEXT NOT NULL, version TEXT NOT NULL, sha256 TEXT NOT NULL,
        model TEXT NOT NULL, path TEXT, rule TEXT NOT NULL, confidence REAL NOT NULL,
        grades TEXT NOT NULL, text TEXT, UNIQUE (name, version, sha256));
    CREATE TABLE runs (
        id INTEGER PRIMARY KEY, path TEXT NOT NULL, start_utc TEXT NOT NULL DEFAULT '',
        stop_utc TEXT, operator TEXT, lot TEXT, station TEXT, software_version TEXT,
        interrupted INTEGER NOT NULL DEFAULT 0, UNIQUE (path, start_utc));
    CREATE TABLE units (
        id INTEGER PRIMARY KEY, model TEXT NOT NULL, serial_number TEXT NOT NULL,
        UNIQUE (model, serial_number));
    CREATE TABLE gradings (
        id INTEGER PRIMARY KEY, run_id INTEGER NOT NULL REFERENCES runs(id),
        unit_id INTEGER NOT NULL REFERENCES units(id),
        profile_id INTEGER NOT NULL REFERENCES profiles(id), run_unit TEXT NOT NULL,
        graded_utc TEXT NOT NULL, lot TEXT NOT NULL DEFAULT '', grade TEXT NOT NULL,
        verdict TEXT NOT NULL CHECK (verdict IN ('pass', 'fail', 'indeterminate')),
        software_version TEXT, notes TEXT);
    CREATE TABLE figures (
        grading_id INTEGER NOT NULL REFERENCES gradings(id) ON DELETE CASCADE,
        axis TEXT NOT NULL, name TEXT NOT NULL, unit TEXT NOT NULL, value REAL, ci_low REAL,
        ci_high REAL, limit_value REAL, verdict TEXT, PRIMARY KEY (grading_id, axis, name));
    CREATE TABLE reports (
        id INTEGER PRIMARY KEY, grading_id INTEGER NOT NULL REFERENCES gradings(id),
        format TEXT NOT NULL, path TEXT NOT NULL, created_utc TEXT NOT NULL);
    """,
    # 2: per-axis grades, the test date, and the indexes the browser filters on
    """
    CREATE TABLE axis_grades (
        grading_id INTEGER NOT NULL REFERENCES gradings(id) ON DELETE CASCADE,
        axis TEXT NOT NULL, grade TEXT NOT NULL, deciding_grade TEXT NOT NULL,
        n_samples INTEGER NOT NULL, sample_rate_hz REAL NOT NULL, PRIMARY KEY (grading_id, axis));
    ALTER TABLE gradings ADD COLUMN test_date TEXT NOT NULL DEFAULT '';
    CREATE INDEX gradings_lot ON gradings (lot);
    CREATE INDEX gradings_test_date ON gradings (test_date);
    CREATE INDEX gradings_unit ON gradings (unit_id);
    CREATE INDEX units_model ON units (model);
    """,
    # 3: review: why a person must look at a grading (read-off and fit disagree); '' when not
    """
    ALTER TABLE gradings ADD COLUMN review TEXT NOT NULL DEFAULT '';
    ALTER TABLE axis_grades ADD COLUMN review TEXT NOT NULL DEFAULT '';
    CREATE INDEX gradings_review ON gradings (review != '');
    """,
    # 4: a grading is one per run, unit in the run and profile file, or a numbered revision:
    # the copies earlier stations stored of one grading (a re-run) become its revisions
    """
    ALTER TABLE gradings ADD COLUMN revision INTEGER NOT NULL DEFAULT 1;
    UPDATE gradings SET revision = (SELECT COUNT(*) FROM gradings g2 WHERE g2.run_id =
        gradings.run_id AND g2.run_unit = gradings.run_unit AND g2.profile_id =
        gradings.profile_id AND g2.id <= gradings.id);
    CREATE UNIQUE INDEX gradings_identity ON gradings (run_id, run_unit, profile_id, revision);
    """,
)
SCHEMA_VERSION = len(MIGRATIONS)


def _equal_to(*filters: tuple[str, str | None]) -> tuple[list[str], list[object]]:
    """SQL ``column = ?`` clauses and their parameters, for the filters whose value is given."""
    given = [(column, value) for column, value in filters if value is not None]
    return [f"{column} = ?" for column, _ in given], [value for _, value in given]


def _grading_filter(*, model: str | None = None, lot: str | None = None, since: str | None = None,
                    until: str | None = None, verdict: str | None = None, serial: str | None = None,
                    latest: bool = False, review: bool = False, station: str | None = None,
                    operator: str | None = None) -> tuple[str, list[object]]:
    """The ``WHERE`` clause (never empty) over gradings ``g`` and units ``u``, and its
    parameters (see :meth:`ResultsDatabase.gradings`)."""
    clauses, params = _equal_to(("u.model", model), ("g.lot", lot), ("g.verdict", verdict),
                                ("u.serial_number", serial))
    for column, value in (("station", station), ("operator", operator)):
        if value is not None:
            clauses.append(f"g.run_id IN (SELECT id FROM runs WHERE {column} = ?)")
            params.append(value)
    if since:
        clauses.append("g.test_date >= ?")
        params.append(since)
    if until:
        clauses.append("g.test_date < ?")
        params.append(until + "\uffff")
    if latest:
        clauses.append("g.id = (SELECT MAX(id) FROM gradings WHERE unit_id = g.unit_id)")
    if review:
        clauses.append("g.review != ''")
    return "WHERE " + " AND ".join(clauses or ["1 = 1"]), params


def default_database_path() -> DatabaseLocation:
    """``$STATION_RESULTS_DB`` (a file or a ``postgresql://`` URL), else
    ``$XDG_DATA_HOME/gyro-station/results.sqlite``."""
    if os.environ.get(DB_ENV):
        return database_location(os.environ[DB_ENV])
    return station_data_database()


def station_data_database() -> Path:
    """``$XDG_DATA_HOME/gyro-station/results.sqlite``: the one database whose folder the
    station makes when it is not there (a ``--db`` or ``$STATION_RESULTS_DB`` in a folder
    that does not exist is refused, not made)."""
    base = Path(os.environ.get("XDG_DATA_HOME") or Path.home() / ".local" / "share")
    return base / "gyro-station" / "results.sqlite"


@dataclass(frozen=True)
class GradingRow:
    """One stored grading of one unit (what ``station results`` lists)."""

    id: int
    test_date: str
    graded_utc: str
    model: str
    serial_number: str
    lot: str
    grade: str
    verdict: Verdict
    profile: str
    run_path: str
    run_unit: str
    review: str = ""
    revision: int = 1

    @property
    def needs_review(self) -> bool:
        """Whether the grading was flagged for a person's review."""
        return bool(self.review)


@dataclass(frozen=True)
class LotYield:
    """Units of a lot by verdict (latest grading of each unit); ``yield_fraction`` is pass/total."""

    lot: str
    model: str
    total: int
    passed: int
    failed: int
    indeterminate: int

    @property
    def yield_fraction(self) -> float:
        """Fraction of the lot's units that pass (0..1)."""
        return self.passed / self.total if self.total else 0.0


@dataclass(frozen=True)
class TrendPoint:
    """A figure of one unit and axis at one test date, in ``unit``."""

    test_date: str
    serial_number: str
    axis: str
    value: float | None
    ci_low: float | None
    ci_high: float | None
    unit: str
    verdict: Verdict | None
    limit: float | None = None


@dataclass(frozen=True)
class FigureValue:
    """One graded figure of one unit's axis, in ``unit``, with the limit it was decided at."""

    grading_id: int
    test_date: str
    serial_number: str
    lot: str
    axis: str
    name: str
    unit: str
    value: float | None
    limit: float | None


class ResultsDatabase:
    """A results database (SQLite file or PostgreSQL URL), migrated to :data:`SCHEMA_VERSION`
    on open.

    Use as a context manager, or call :meth:`close`.

    Raises
    ------
    ResultsDatabaseError
        When the file is not a database, the server cannot be reached, or the database was
        written by a newer schema.
    DatabaseLocationError
        ``location`` cannot be a results database (a folder, a file of something else, a
        folder that does not exist, an unknown URL scheme): not an outage.

    ``read_only``: nothing is written, the schema neither created nor migrated; a database
    file that does not exist yet or is empty, or a server database without the schema,
    reads as an empty results database (``station serve``).
    """

    def __init__(self, location: DatabaseLocation, *, read_only: bool = False) -> None:
        self.location = location if is_database_url(location) else Path(location)
        self.read_only = read_only
        self._con: Backend = self._connect(read_only)
        self.name = self._con.name
        try:
            if read_only:
                self._check_readable()
            else:
                self._migrate()
        except (ResultsDatabaseError, UsageError):
            self._con.close()
            raise
        except Exception as exc:  # sqlite3 or psycopg: a file that is no database, a server error
            self._con.close()
            raise ResultsDatabaseError(f"{self.name}: {str(exc).strip().splitlines()[0]}") from exc

    @property
    def path(self) -> Path:
        """The SQLite file (a PostgreSQL database has none)."""
        if isinstance(self.location, Path):
            return self.location
        raise ResultsDatabaseError(f"{self.name} is a PostgreSQL database, not a file")

    @property
    def errors(self) -> tuple[type[BaseException], ...]:
        """The driver's errors a statement may raise (``sqlite3.Error``, ``psycopg.Error``):
        a reader that must survive a server going away catches these."""
        return self._con.errors

    def __enter__(self) -> ResultsDatabase:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the connection."""
        self._con.close()

    @contextmanager
    def transaction(self) -> Iterator[Backend]:
        """One write transaction (SQLite: ``BEGIN IMMEDIATE``): committed whole, or not at all."""
        with self._con.transaction():
            yield self._con

    @property
    def schema_version(self) -> int:
        """The schema version of the database (0: new)."""
        return self._con.schema_version()

    def _connect(self, read_only: bool) -> Backend:
        if read_only and isinstance(self.location, Path) and (
                not self.location.exists() or self.location.stat().st_size == 0):
            check_database_file(self.location)
            return self._empty(self.location)
        default = isinstance(self.location, Path) and self.location == station_data_database()
        return open_backend(self.location, create_folder=default, read_only=read_only)

    @staticmethod
    def _empty(location: DatabaseLocation) -> Backend:
        """An empty results database in memory, named after ``location``."""
        empty = SqliteBackend.in_memory()
        empty.name = redacted(location)
        with empty.migration():
            empty.run_ddl(SCHEMA_MIGRATIONS_TABLE)
            for number, script in enumerate(MIGRATIONS, start=1):
                empty.run_ddl(script)
                empty.set_schema_version(number)
        return empty

    def _check_readable(self) -> None:
        """Read-only: a database without the schema reads as empty; one of another schema
        version is refused (migrating it would write)."""
        version = self.schema_version
        if version == SCHEMA_VERSION:
            return
        if version == 0 and not self._con.has_tables():
            self._con.close()
            self._con = self._empty(self.location)
            return
        if version == 0:
            self._refuse_foreign_tables()
            version = self.schema_version  # a station migrated it meanwhile
            if version == SCHEMA_VERSION:
                return
        raise ResultsDatabaseError(
            f"{self.name}: schema version {version}, this station reads {SCHEMA_VERSION}: "
            + ("update the station" if version > SCHEMA_VERSION else
               "station grade (any grading stored) migrates it"))

    def _refuse_foreign_tables(self) -> None:
        """Refuse a database whose tables are not a results database's: tables with no schema
        version, read in that order. A station's migration commits its tables and its version
        together, so a version still 0 after its tables were seen is no migration's; the
        other order can straddle one's commit (eight stations opening one new PostgreSQL
        database: a version of 0 read just before it, the tables just after)."""
        if self._con.has_tables() and self.schema_version == 0:
            raise DatabaseLocationError(f"{self.name} holds tables of something else: it "
                                        "is not a results database")

    def _migrate(self) -> None:
        if self.schema_version == SCHEMA_VERSION:
            return
        self._refuse_foreign_tables()
        with self._con.migration():  # re-read inside the lock: another station may have migrated
            con = self._con
            version = self.schema_version
            if version > SCHEMA_VERSION:
                raise ResultsDatabaseError(
                    f"{self.name}: schema version {version} is newer than this "
                    f"station's {SCHEMA_VERSION}; update the station"
                )
            con.run_ddl(SCHEMA_MIGRATIONS_TABLE)
            for number in range(version + 1, SCHEMA_VERSION + 1):
                con.run_ddl(MIGRATIONS[number - 1])
                con.execute("INSERT INTO schema_migrations VALUES (?, ?)", (number, now_utc()))
                con.set_schema_version(number)

    # --- writing ------------------------------------------------------------------------

    def store(self, graded: RunGrade, reports: Sequence[ReportFile] = (), *,
              join: bool = False) -> list[int]:
        """Store every unit of a graded run, and the report files written for it, in one
        transaction; returns the grading ids, one per unit.

        Storing the same grading again returns the stored one; a different grading of the
        same run, unit and profile file is stored as its next revision, or with ``join``
        the stored one is kept (:mod:`station.output.results_store`). A transaction the
        server aborted to break a deadlock with another station is tried again (up to
        ``WRITE_ATTEMPTS`` times).

        Raises
        ------
        SerialConflictError
            A unit's serial number is another unit's (nothing of the run is stored).
        ResultsDatabaseError
            The database cannot take the grading (a server gone, a disk full).
        """
        for attempt in range(1, WRITE_ATTEMPTS + 1):
            try:
                with self.transaction() as con:
                    return store_run(con, graded, reports, join=join)
            except self._con.retryable as exc:
                if attempt == WRITE_ATTEMPTS:
                    raise ResultsDatabaseError(f"{self.name}: {exc}") from exc
            except self._con.errors as exc:
                raise ResultsDatabaseError(f"{self.name}: cannot store the grading: "
                                           f"{str(exc).strip().splitlines()[0]}") from exc
        raise AssertionError("unreachable")

    def add_report(self, grading_id: int, fmt: str, path: str | Path) -> None:
        """Record a report file written for a grading (once)."""
        with self.transaction() as con:
            add_report(con, grading_id, fmt, path)

    # --- reading ------------------------------------------------------------------------

    def gradings(
        self,
        *,
        model: str | None = None,
        lot: str | None = None,
        since: str | None = None,
        until: str | None = None,
        verdict: Verdict | None = None,
        serial: str | None = None,
        latest: bool = False,
        review: bool = False,
        station: str | None = None,
        operator: str | None = None,
    ) -> list[GradingRow]:
        """Stored gradings, oldest first, filtered; dates compare as ISO 8601 text (``until``
        includes that whole day). ``latest`` keeps only each unit's newest grading, ``review``
        only the gradings flagged for review; ``station`` and ``operator`` those of runs
        recorded there, by them."""
        where, params = _grading_filter(
            model=model, lot=lot, since=since, until=until, verdict=verdict, serial=serial,
            latest=latest, review=review, station=station, operator=operator,
        )
        rows = self._con.execute(
            "SELECT g.id, g.test_date, g.graded_utc, u.model, u.serial_number, g.lot, g.grade, "
            "g.verdict,"
            " p.name || '@' || p.version AS profile, r.path AS run_path, g.run_unit, g.review,"
            " g.revision FROM "
            "gradings g"
            " JOIN units u ON u.id = g.unit_id JOIN profiles p ON p.id = g.profile_id"
            f" JOIN runs r ON r.id = g.run_id {where} ORDER BY g.test_date, g.id",
            params,
        ).fetchall()
        return [GradingRow(*row) for row in rows]

    def figure_values(self, *, model: str | None = None, lot: str | None = None,
                      since: str | None = None) -> list[FigureValue]:
        """The graded figures (those a grade limits) of each unit's latest grading, filtered
        as :meth:`gradings` filters, in test order (date, grading, axis, name)."""
        where, params = _grading_filter(model=model, lot=lot, since=since, latest=True)
        rows = self._con.execute(
            "SELECT g.id, g.test_date, u.serial_number, g.lot, f.axis, f.name, f.unit, f.value,"
            " f.limit_value FROM figures f JOIN gradings g ON g.id = f.grading_id"
            f" JOIN units u ON u.id = g.unit_id {where} AND f.verdict IS NOT NULL"
            " ORDER BY g.test_date, g.id, f.axis, f.name", params).fetchall()
        return [FigureValue(*row) for row in rows]

    def profile_text(self, grading_id: int) -> tuple[str, str | None]:
        """(``name@version``, TOML text or None) of the profile a grading used."""
        row = self._con.execute("SELECT p.name || '@' || p.version, p.text FROM gradings g JOIN"
                                " profiles p ON p.id = g.profile_id WHERE g.id = ?",
                                (grading_id,)).fetchone()
        return (str(row[0]), row[1]) if row else ("", None)

    def latest_grading(
        self, run_path: str | Path, run_unit: str, profile_sha256: str
    ) -> int | None:
        """Id of the newest grading of one unit of a run with one profile file, if stored."""
        row = self._con.execute(
            "SELECT MAX(g.id) FROM gradings g JOIN runs r ON r.id = g.run_id JOIN profiles p"
            " ON p.id = g.profile_id WHERE r.path = ? AND g.run_unit = ? AND p.sha256 = ?",
            (str(Path(run_path).resolve()), run_unit, profile_sha256)).fetchone()
        return None if row[0] is None else int(row[0])

    def figures(self, grading_id: int) -> list[Any]:
        """The figure rows of one grading (by column name or position), by axis and name."""
        return self._con.execute("SELECT * FROM figures WHERE grading_id = ? ORDER BY axis, name",
                                 (grading_id,)).fetchall()

    def reports(self, grading_id: int) -> list[Any]:
        """The report files recorded for one grading."""
        return self._con.execute("SELECT * FROM reports WHERE grading_id = ? ORDER BY id",
                                 (grading_id,)).fetchall()

    def yield_by_lot(self, *, model: str | None = None) -> list[LotYield]:
        """Per lot (and model), the latest grading of each unit counted by verdict."""
        rows = self._con.execute(
            "SELECT g.lot, u.model, COUNT(*), SUM(CASE WHEN g.verdict = 'pass' THEN 1 ELSE 0 END),"
            " SUM(CASE WHEN g.verdict = 'fail' THEN 1 ELSE 0 END),"
            " SUM(CASE WHEN g.verdict = 'indeterminate' THEN 1 ELSE 0 END)"
            " FROM gradings g JOIN units u ON u.id = g.unit_id"
            " WHERE g.id = (SELECT MAX(id) FROM gradings WHERE unit_id = g.unit_id)"
            + (" AND u.model = ?" if model else "")
            + " GROUP BY g.lot, u.model ORDER BY g.lot, u.model",
            (model,) if model else (),
        ).fetchall()
        return [LotYield(*row) for row in rows]

    def trend(self, figure: str, *, model: str | None = None, axis: str | None = None,
              lot: str | None = None) -> list[TrendPoint]:
        """A figure over test dates, one point per grading and axis, oldest first.

        Raises
        ------
        UsageError
            A figure no grading in the database has (the names stored are listed).
        """
        names = self.figure_names()
        if figure not in names:
            raise UsageError(f"no figure {figure!r} in the results database; its figures: "
                             f"{', '.join(names) or 'none yet (station grade stores them)'}")
        clauses, params = _equal_to(("f.name", figure), ("u.model", model), ("f.axis", axis),
                                    ("g.lot", lot))
        rows = self._con.execute(
            "SELECT g.test_date, u.serial_number, f.axis, f.value, f.ci_low, f.ci_high, f.unit, "
            "f.verdict,"
            " f.limit_value"
            " FROM figures f JOIN gradings g ON g.id = f.grading_id JOIN units u ON u.id = "
            "g.unit_id"
            f" WHERE {' AND '.join(clauses)} ORDER BY g.test_date, g.id, f.axis",
            params,
        ).fetchall()
        return [TrendPoint(*row) for row in rows]

    def distinct_names(self) -> dict[str, list[str]]:
        """The models, stations and operators the database holds, sorted (what a line's
        gradings can be filtered by)."""
        queries = {"models": "SELECT DISTINCT model FROM units",
                   "stations": "SELECT DISTINCT station FROM runs WHERE station IS NOT NULL",
                   "operators": "SELECT DISTINCT operator FROM runs WHERE operator IS NOT NULL"}
        return {key: sorted(str(row[0]) for row in self._con.execute(sql).fetchall() if row[0])
                for key, sql in queries.items()}

    def figure_names(self) -> list[str]:
        """The names of the figures stored (``arw``, ``bias_instability``, ...), sorted."""
        query = "SELECT DISTINCT name FROM figures ORDER BY name"
        return [row[0] for row in self._con.execute(query).fetchall()]

    def state(self) -> tuple[int, ...]:
        """What changes whenever a grading, a revision or a report file is stored (gradings,
        their highest id, reports): what is drawn from the database is the same while this is."""
        row = self._con.execute("SELECT COUNT(*), COALESCE(MAX(id), 0) FROM gradings").fetchone()
        reports = self._con.execute("SELECT COUNT(*) FROM reports").fetchone()
        return (int(row[0]), int(row[1]), int(reports[0]))

    def integrity_check(self) -> str:
        """ "ok" when sound (SQLite: its ``PRAGMA integrity_check`` answer)."""
        return self._con.integrity_check()


def export_csv(rows: Sequence[GradingRow], path: str | Path) -> Path:
    """Write grading rows as CSV (header of :class:`GradingRow` field names), whole or
    not at all (:func:`replacing`)."""
    path = Path(path)
    fields = list(GradingRow.__dataclass_fields__)
    with replacing(path) as tmp, tmp.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(fields)
        for row in rows:
            writer.writerow([getattr(row, f) for f in fields])
    return path
