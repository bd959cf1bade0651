"""The results database on a production day: a grading stored twice is one grading (or its
next revision), an old database's copies become revisions, a serial another unit has is
refused, and a real PostgreSQL server stopped while gradings are stored: the stores are
tried again with back-off, what is still not stored is said (exit 1), and grading again
after the server is back stores each run once."""

from __future__ import annotations

import asyncio
import json
import socket
import threading
import time
from dataclasses import replace
from pathlib import Path

import pytest

from station.cli import main
from station.errors import ResultsDatabaseError, SerialConflictError
from station.evaluation.grading import RunGrade
from station.output.results import MIGRATIONS, ResultsDatabase
from station.output.results_backends import open_backend
from station.output.results_queue import FIRST_BACKOFF_S, StoreQueue
from tests.postgres_server import PostgresServer
from tests.test_results_db import _variant, setup  # noqa: F401 - the module's fixture
from tests.test_tui import SIZE, notifications, until

START, STOP = "2026-05-04T08:00:00Z", "2026-05-04T09:00:00Z"


@pytest.fixture(params=["sqlite", "postgresql"])
def location(request, tmp_path: Path) -> str | Path:
    if request.param == "sqlite":
        return tmp_path / "results.sqlite"
    return request.getfixturevalue("postgres_url")


def _timed(graded: RunGrade, start: str, stop: str, serial: str = "SN-9") -> RunGrade:
    g = _variant(graded, serial, "L1", start, graded.units[0].grade)
    return replace(g, run=replace(g.run, stop_utc=stop))


def _two_units(graded: RunGrade, serials: tuple[str, str]) -> RunGrade:
    u = graded.units[0]
    units = tuple(replace(u.unit, unit_id=f"unit{i + 1}", serial_number=s)
                  for i, s in enumerate(serials))
    run = replace(graded.run, start_utc=START, stop_utc=STOP, units=units)
    return replace(graded, run=run, units=tuple(replace(u, unit=x) for x in units))


def test_old_database_copies_become_revisions(location, setup) -> None:  # noqa: F811
    """A database of schema 3 (before revisions), as earlier stations left it after a fleet
    was run again following an outage: two copies of one grading. Migrated, the copies are
    revisions 1 and 2, the latest is still the newest, a third copy is refused by the
    database itself, and new gradings store as before."""
    con = open_backend(location)
    with con.migration():
        con.run_ddl("CREATE TABLE schema_migrations (version INTEGER PRIMARY KEY, "
                    "applied_utc TEXT NOT NULL)")
        for number, ddl in enumerate(MIGRATIONS[:3], start=1):
            con.run_ddl(ddl)
            con.execute("INSERT INTO schema_migrations VALUES (?, '2026-01-01T00:00:00Z')",
                        (number,))
            con.set_schema_version(number)
    with con.transaction():
        con.execute("INSERT INTO profiles (name, version, sha256, model, rule, confidence,"
                    " grades) VALUES ('P', '1', 'abc', 'M', 'plain', 0.95, '[\"A\"]')")
        con.execute("INSERT INTO runs (path, start_utc) VALUES ('/runs/a.h5', ?)", (START,))
        con.execute("INSERT INTO units (model, serial_number) VALUES ('M', 'SN-1'), ('M', 'SN-2')")
        for unit, grade in ((1, "A"), (1, "B"), (2, "A")):
            con.execute("INSERT INTO gradings (run_id, unit_id, profile_id, run_unit,"
                        " graded_utc, lot, grade, verdict) VALUES (1, ?, 1, ?, ?, 'L', ?,"
                        " 'pass')", (unit, f"unit{unit}", START, grade))
    con.close()
    with ResultsDatabase(location) as db:
        rows = db.gradings()
        assert [(r.run_unit, r.revision, r.grade) for r in rows] == [
            ("unit1", 1, "A"), ("unit1", 2, "B"), ("unit2", 1, "A")]
        assert [r.id for r in db.gradings(latest=True)] == [rows[1].id, rows[2].id]
        with pytest.raises(ResultsDatabaseError):  # a second revision 2: the index refuses
            with db.transaction() as c:
                try:
                    c.execute("INSERT INTO gradings (run_id, unit_id, profile_id, run_unit,"
                              " graded_utc, lot, grade, verdict, revision) VALUES"
                              " (1, 1, 1, 'unit1', '', 'L', 'A', 'pass', 2)")
                except Exception as exc:  # sqlite3 or psycopg: the unique index
                    raise ResultsDatabaseError(str(exc)) from exc
        assert len(db.store(setup[2])) == 1 and len(db.gradings()) == 4


def test_storing_twice_is_one_grading_and_a_changed_one_a_revision(location, setup) -> None:  # noqa: F811
    graded = setup[2]
    with ResultsDatabase(location) as db:
        ids = db.store(graded)
        assert db.store(replace(graded, graded_utc="2030-01-01T00:00:00Z")) == ids
        assert [r.revision for r in db.gradings()] == [1]
        regraded = replace(graded, units=(replace(graded.units[0], grade="B"),))
        again = db.store(regraded)
        rows = db.gradings()
        assert again != ids and [(r.revision, r.grade) for r in rows] == [
            (1, graded.units[0].grade), (2, "B")]
        assert [r.id for r in db.gradings(latest=True)] == again
        assert db.store(regraded) == again and len(db.gradings()) == 2


def test_a_serial_another_unit_has_is_refused(location, setup) -> None:  # noqa: F811
    """Two units of one run both SIM-0, or one serial in two runs recorded at the same time:
    refused (nothing of that run stored), not one grading standing for the other's; the
    same serial in a later run is the unit tested again."""
    graded = setup[2]
    with ResultsDatabase(location) as db:
        with pytest.raises(SerialConflictError, match="unit unit2 reports serial 'SIM-0'.*"
                           "unit unit1 of the same run"):
            db.store(_two_units(graded, ("SIM-0", "SIM-0")))
        assert db.gradings() == []
        assert len(db.store(_two_units(graded, ("SIM-1", "SIM-2")))) == 2
        overlapping = _timed(graded, "2026-05-04T08:30:00Z", "2026-05-04T09:30:00Z", "SIM-1")
        overlapping = replace(overlapping, run=replace(overlapping.run, path="/other/run.h5"))
        with pytest.raises(SerialConflictError, match="recorded at the same time"):
            db.store(overlapping)
        later = _timed(graded, "2026-05-05T08:00:00Z", "2026-05-05T09:00:00Z", "SIM-1")
        later = replace(later, run=replace(later.run, path="/other/retest.h5"))
        (retest,) = db.store(later)
        latest = {r.serial_number: r.id for r in db.gradings(latest=True)}
        assert latest["SIM-1"] == retest and len(latest) == 2


@pytest.mark.slow
def test_store_queue_waits_for_the_server_with_back_off(
    setup, postgres_server: PostgresServer, postgres_url: str  # noqa: F811
) -> None:
    """The server stopped: the store fails and waits; the server back 1.5 s later: the
    store goes in on a new connection, the tries spaced by a growing back-off. Stopped
    for longer than ``retry_s``: the run is listed as not stored, with the reason."""
    graded = setup[2]
    sleeps: list[float] = []

    def sleep(s: float) -> None:
        sleeps.append(s)
        time.sleep(s)

    with StoreQueue(postgres_url, retry_s=30.0, sleep=sleep) as queue:
        queue.open()
        postgres_server.stop()
        restart, started = threading.Timer(1.5, postgres_server.start), False
        try:
            queue.put("run", graded)
            assert queue.waiting == 1 and queue.stored == {}
            restart.start()
            started, t0 = True, time.monotonic()
            assert queue.finish() == []
        finally:
            restart.join() if started else postgres_server.start()
        assert 1.0 < time.monotonic() - t0 < 12.0 and len(queue.stored["run"]) == 1
    tries = [s for s in sleeps if s > 0.01]
    assert tries[0] == pytest.approx(FIRST_BACKOFF_S, abs=0.05) and tries == sorted(tries)
    with ResultsDatabase(postgres_url) as db:
        assert len(db.gradings()) == 1
    postgres_server.stop()
    try:
        with StoreQueue(postgres_url, retry_s=1.0) as queue:
            t0 = time.monotonic()
            queue.put("run", graded)
            (lost,) = queue.finish()
            assert 1.0 <= time.monotonic() - t0 < 5.0
        assert lost.file == "run" and lost.units == ("unit",) and "cannot open" in lost.error
    finally:
        postgres_server.start()


def test_grade_with_the_server_stopped_says_so_and_grading_again_stores_once(
    setup, postgres_server: PostgresServer, postgres_url: str, capsys  # noqa: F811
) -> None:
    record, profile, _ = setup
    args = ["grade", str(record), "--profile", str(profile), "--db", postgres_url, "--json"]
    with ResultsDatabase(postgres_url):
        pass  # the database exists, migrated
    postgres_server.stop()
    try:
        assert main([*args, "--db-retry", "0.5"]) == 1
    finally:
        postgres_server.start()
    out, err = capsys.readouterr()
    assert json.loads(out)["units"][0]["grade"]  # the grading is shown all the same
    assert len(err.strip().splitlines()) == 1 and "grading not stored" in err
    assert "grade it again" in err
    for _ in range(2):  # the server back: stored, and once only
        assert main(args) == 0
    capsys.readouterr()
    with ResultsDatabase(postgres_url) as db:
        assert len(db.gradings()) == 1


def test_the_tui_says_a_grading_was_not_stored(tmp_path: Path) -> None:
    from tests.test_tui import write_run

    run = write_run(tmp_path / "runs" / "run-1.h5", duration_s=600.0)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # nobody listens there once closed
    asyncio.run(_not_stored_notice(run, f"postgresql://station@127.0.0.1:{port}/results"))


async def _not_stored_notice(run: Path, url: str) -> None:
    from station.tui.app import StationApp, TuiSettings
    from station.tui.spec_screen import SpecSheetScreen

    app = StationApp(TuiSettings(runs_dir=run.parent, reports_dir=run.parent, db_path=url,
                                 db_retry_s=0.3, attach=False, check_units=False))
    async with app.run_test(size=SIZE, notifications=True) as pilot:
        app.push_screen(SpecSheetScreen(run, run.parent, url, db_retry_s=0.3))
        sheet = app.screen
        await until(pilot, lambda: sheet.graded is not None, 40, "the grading")
        await until(pilot, lambda: "NOT stored" in notifications(app), 20, "the notice")
        text = notifications(app)
        assert "Open this spec sheet again once the database answers" in text
        assert "cannot open the results database" in text
