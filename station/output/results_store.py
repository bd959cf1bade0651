"""Writing a graded run into the results database, inside one write transaction.

Idempotent: a grading is identified by its run, the unit's place in that run and the
profile file (``gradings.run_id, run_unit, profile_id``); storing the same grading again
(a re-run after an outage, a spec sheet opened twice) returns the stored one. A grading of
the same run, unit and profile that differs (a newer station that grades otherwise) is
stored beside it as the next ``revision``, the earlier ones kept.

Identity: the results database keeps the latest grading of each unit (model and serial
number). A unit whose serial number is already another unit's, in the same run or in a
run recorded at the same time, cannot be that unit: the run is refused with
:class:`~station.errors.SerialConflictError` instead of one unit's grading standing for
the other's.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from station.errors import SerialConflictError
from station.model.kinds import verdict_of_grade
from station.output.results_backends import Backend

if TYPE_CHECKING:
    from station.evaluation.grading import RunGrade, UnitGrade

#: The ``axis`` of a figure of the whole unit: a test sequence's figures (each the worst
#: of the unit's axes), stored beside the axes' figures under their profile names
#: (``turn_on_repeatability``, ``temperature_coefficient``, ...).
UNIT_AXIS = ""
#: A report file of a run: (format, path).
ReportFile = tuple[str, str | Path]

#: What makes two gradings of a run's unit the same (the test date of a record without a
#: start time is the grading's time, so it is left out).
_GRADING_CONTENT = "lot, grade, verdict, notes, review"
_AXIS_COLUMNS = "axis, grade, deciding_grade, n_samples, sample_rate_hz, review"
_FIGURE_COLUMNS = "axis, name, unit, value, ci_low, ci_high, limit_value, verdict"


def now_utc() -> str:
    """The time now, UTC, to the second (ISO 8601 with ``Z``)."""
    return datetime.now(UTC).replace(microsecond=0).isoformat().replace("+00:00", "Z")


def row_id(con: Backend, table: str, keys: dict[str, object],
           extra: dict[str, object] | None = None) -> int:
    """Id of the row with ``keys``, added (with ``extra``) when there is none; another
    station adding the same row at the same time is no error (``ON CONFLICT``)."""
    where = " AND ".join(f"{k} = ?" for k in keys)
    select = f"SELECT id FROM {table} WHERE {where}"
    row = con.execute(select, tuple(keys.values())).fetchone()
    if row is None:
        cols = {**keys, **(extra or {})}
        row = con.execute(f"INSERT INTO {table} ({', '.join(cols)}) VALUES "
                          f"({', '.join('?' * len(cols))}) ON CONFLICT DO NOTHING RETURNING id",
                          tuple(cols.values())).fetchone()
        if row is None:  # the other station's row, committed while this insert waited
            row = con.execute(select, tuple(keys.values())).fetchone()
    return int(row[0])


def _plain(value: Any) -> Any:
    """A value as the database gives it back (numpy scalars as Python's, NaN as NULL)."""
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and math.isnan(value):
        return None
    return value


def _plain_rows(rows: Sequence[Sequence[Any]]) -> list[tuple[Any, ...]]:
    return sorted((tuple(_plain(v) for v in row) for row in rows), key=repr)


class _UnitRows:
    """What one unit's grading stores: the grading's content, its axes and its figures."""

    def __init__(self, graded: RunGrade, u: UnitGrade) -> None:
        self.unit = u
        self.test_date = graded.run.start_utc or graded.graded_utc
        self.content = (graded.run.metadata.lot, u.grade,
                        verdict_of_grade(u.grade, graded.profile.reject), "\n".join(u.notes),
                        "\n".join(u.review))
        self.axes = [(a.axis, a.grade, a.deciding_grade, a.analysis.n_samples,
                      a.analysis.sample_rate_hz, "\n".join(a.review)) for a in u.axes]
        self.figures: list[tuple[Any, ...]] = []
        for a in u.axes:
            for f in a.figures:
                verdict = f.verdicts.get(a.deciding_grade, "pass") if f.spec.graded else None
                self.figures.append((a.axis, f.name, f.spec.unit, f.value, f.ci_low, f.ci_high,
                                     f.spec.limits.get(a.deciding_grade), verdict))
        if u.sequence is not None:  # the unit's own figures: axis ''
            grade = u.sequence.deciding_grade
            for g in u.sequence.graded:
                limited = bool(g.spec.limits) and bool(grade)
                self.figures.append((UNIT_AXIS, g.spec.name, g.spec.unit, g.value, g.ci_low,
                                     g.ci_high, g.spec.limits.get(grade) if limited else None,
                                     g.verdicts.get(grade, "pass") if limited else None))

    def same_as_stored(self, con: Backend, grading_id: int) -> bool:
        """Whether the stored grading ``grading_id`` holds exactly these rows."""
        stored = con.execute(f"SELECT {_GRADING_CONTENT} FROM gradings WHERE id = ?",
                             (grading_id,)).fetchone()
        if _plain_rows([tuple(stored)]) != _plain_rows([self.content]):
            return False
        axes = con.execute(f"SELECT {_AXIS_COLUMNS} FROM axis_grades WHERE grading_id = ?",
                           (grading_id,)).fetchall()
        figures = con.execute(f"SELECT {_FIGURE_COLUMNS} FROM figures WHERE grading_id = ?",
                              (grading_id,)).fetchall()
        return (_plain_rows(axes) == _plain_rows(self.axes)
                and _plain_rows(figures) == _plain_rows(self.figures))


def _check_identity(con: Backend, graded: RunGrade, unit_id: int, run_id: int, u: UnitGrade,
                    serial: str) -> None:
    """Refuse a unit whose serial another unit has: in this run under another unit id, or
    in another run recorded at the same time (one gyro cannot be on two benches at once).

    Raises
    ------
    SerialConflictError
        Naming both units and what to do.
    """
    run = graded.run
    start, stop = run.start_utc, run.stop_utc or run.start_utc
    row = con.execute(
        "SELECT g.run_unit, r.path, r.id FROM gradings g JOIN runs r ON r.id = g.run_id"
        " WHERE g.unit_id = ? AND ((g.run_id = ? AND g.run_unit != ?) OR (g.run_id != ?"
        " AND ? != '' AND r.start_utc != '' AND r.start_utc != ? AND r.start_utc < ?"
        " AND ? < COALESCE(NULLIF(r.stop_utc, ''), r.start_utc))) ORDER BY g.id LIMIT 1",
        (unit_id, run_id, u.unit.unit_id, run_id, start, start, stop, start)).fetchone()
    if row is None:
        return
    other_unit, other_path, other_run = row[0], row[1], row[2]
    where = ("the same run" if other_run == run_id
             else f"{other_path}, recorded at the same time")
    raise SerialConflictError(
        f"{run.path}: unit {u.unit.unit_id} reports serial {serial!r} (model "
        f"{u.unit.model or graded.profile.model}), which unit {other_unit} of {where} has in "
        f"the results database: not stored, so that one unit's grading does not stand for "
        f"the other's; give each unit its own serial (a simulated unit: seed=N) and grade "
        f"again")


def store_run(con: Backend, graded: RunGrade, reports: Sequence[ReportFile] = (), *,
              join: bool = False) -> list[int]:
    """Store every unit of ``graded`` (and the report files written for it) in the open
    transaction ``con``; returns the grading ids, one per unit. ``join``: a unit already
    graded from this run with this profile file keeps its latest stored grading (the
    reports are recorded against it), whatever the new grading says.

    Raises
    ------
    SerialConflictError
        A unit's serial number is another unit's (:func:`_check_identity`).
    """
    p, r = graded.profile, graded.run
    try:
        text = Path(p.path).read_text(encoding="utf-8") if p.path else None
    except OSError:
        text = None
    profile_id = row_id(
        con, "profiles", {"name": p.name, "version": p.version, "sha256": p.sha256},
        {"model": p.model, "path": p.path, "rule": p.rule, "confidence": p.confidence,
         "grades": json.dumps(list(p.grades)), "text": text})
    run_id = row_id(
        con, "runs", {"path": str(Path(r.path).resolve()), "start_utc": r.start_utc},
        {"stop_utc": r.stop_utc, "operator": r.metadata.operator, "lot": r.metadata.lot,
         "station": r.metadata.station_host, "software_version": r.metadata.software_version,
         "interrupted": int(r.interrupted)})
    ids = [_store_unit(con, graded, _UnitRows(graded, u), profile_id, run_id, join)
           for u in graded.units]
    for grading_id in ids:
        for fmt, path in reports:
            add_report(con, grading_id, fmt, path)
    return ids


def _store_unit(con: Backend, graded: RunGrade, rows: _UnitRows, profile_id: int,
                run_id: int, join: bool) -> int:
    u = rows.unit
    model = u.unit.model or graded.profile.model
    serial = u.unit.serial_number or u.unit.unit_id
    unit_id = row_id(con, "units", {"model": model, "serial_number": serial})
    con.lock(f"unit {unit_id}")  # another station storing this unit waits: both see each other
    con.lock(f"gradings {run_id} {u.unit.unit_id} {profile_id}")  # one revision at a time
    _check_identity(con, graded, unit_id, run_id, u, serial)
    latest = con.execute(
        "SELECT id, revision FROM gradings WHERE run_id = ? AND run_unit = ? AND profile_id = ?"
        " ORDER BY revision DESC LIMIT 1", (run_id, u.unit.unit_id, profile_id)).fetchone()
    if latest is not None and (join or rows.same_as_stored(con, int(latest[0]))):
        return int(latest[0])  # stored before (a re-run, a spec sheet opened again)
    revision = 1 if latest is None else int(latest[1]) + 1
    grading_id = int(con.execute(
        "INSERT INTO gradings (run_id, unit_id, profile_id, run_unit, graded_utc, test_date,"
        f" {_GRADING_CONTENT}, software_version, revision)"
        " VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id",
        (run_id, unit_id, profile_id, u.unit.unit_id, graded.graded_utc, rows.test_date,
         *rows.content,
         graded.software_version, revision)).fetchone()[0])
    for axis in rows.axes:
        con.execute(f"INSERT INTO axis_grades (grading_id, {_AXIS_COLUMNS})"
                    " VALUES (?, ?, ?, ?, ?, ?, ?)", (grading_id, *axis))
    for figure in rows.figures:
        con.execute(f"INSERT INTO figures (grading_id, {_FIGURE_COLUMNS})"
                    " VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)", (grading_id, *figure))
    return grading_id


def add_report(con: Backend, grading_id: int, fmt: str, path: str | Path, *,
               created_utc: str = "") -> None:
    """Record a report file written for a grading, once (the same file again is no new row)."""
    where = (grading_id, fmt, str(Path(path).resolve()))
    if con.execute("SELECT 1 FROM reports WHERE grading_id = ? AND format = ? AND path = ?",
                   where).fetchone() is None:
        con.execute("INSERT INTO reports (grading_id, format, path, created_utc)"
                    " VALUES (?, ?, ?, ?)", (*where, created_utc or now_utc()))
