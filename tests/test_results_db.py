"""The results database: migrations, storing and filtering, yield, trends, CSV, concurrency,
crashes, on SQLite and on a real PostgreSQL server (tests/postgres_server.py)."""

from __future__ import annotations

import csv
import os
import re
import signal
import socket
import sqlite3
import subprocess
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path

import pytest

from station.cli import main
from station.errors import ResultsDatabaseError, UsageError
from station.evaluation.grading import RunGrade, grade_run
from station.model.profiles import load_profile
from station.output.results import MIGRATIONS, SCHEMA_VERSION, ResultsDatabase, export_csv
from station.storage.runs import open_run
from tests.test_grading import make_record, profile_text, write_profile

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def setup(tmp_path_factory) -> tuple[Path, Path, RunGrade]:
    """A record, a profile file, and the record graded with it."""
    d = tmp_path_factory.mktemp("db")
    record = make_record(d / "unit.csv", n=6_000, seed=11)
    profile = write_profile(d, profile_text(warmup_s=10.0, duration_s=600.0))
    return record, profile, grade_run(open_run(record), load_profile(profile))


def _variant(graded: RunGrade, serial: str, lot: str, start: str, grade: str) -> RunGrade:
    """The same grading as another unit, lot, date and grade (what several runs would give)."""
    unit = graded.units[0]
    run = replace(graded.run, metadata=replace(graded.run.metadata, lot=lot), start_utc=start,
                  units=(replace(unit.unit, serial_number=serial),))
    return replace(graded, run=run, units=(replace(unit, unit=run.units[0], grade=grade),))


def test_fresh_database_is_migrated(tmp_path: Path) -> None:
    with ResultsDatabase(tmp_path / "r.sqlite") as db:
        assert db.schema_version == SCHEMA_VERSION == len(MIGRATIONS)
        assert db.integrity_check() == "ok"
    con = sqlite3.connect(tmp_path / "r.sqlite")
    assert [r[0] for r in con.execute("SELECT version FROM schema_migrations")] == list(
        range(1, SCHEMA_VERSION + 1))
    assert con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_old_schema_is_migrated_keeping_its_rows(tmp_path: Path, setup) -> None:
    path = tmp_path / "old.sqlite"
    con = sqlite3.connect(path)
    con.executescript(MIGRATIONS[0])
    con.execute(
        "CREATE TABLE schema_migrations (version INTEGER PRIMARY KEY, applied_utc TEXT NOT NULL)"
    )
    con.execute("INSERT INTO schema_migrations VALUES (1, '2026-01-01T00:00:00Z')")
    con.execute("INSERT INTO units (model, serial_number) VALUES ('M', 'OLD-1')")
    con.execute("PRAGMA user_version = 1")
    con.commit()
    con.close()
    with ResultsDatabase(path) as db:
        assert db.schema_version == SCHEMA_VERSION
        db.store(setup[2])  # the new tables and columns are there
        assert len(db.gradings()) == 1
    assert sqlite3.connect(path).execute(
        "SELECT serial_number FROM units WHERE model = 'M'"
    ).fetchone() == ("OLD-1",)


def test_newer_schema_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "new.sqlite"
    con = sqlite3.connect(path)
    con.execute(f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    con.close()
    with pytest.raises(ResultsDatabaseError, match="newer"):
        ResultsDatabase(path)
    (tmp_path / "junk.sqlite").write_bytes(b"not a database at all" * 100)
    with pytest.raises(ResultsDatabaseError):
        ResultsDatabase(tmp_path / "junk.sqlite")
    (tmp_path / "a-file").write_text("")
    with pytest.raises(ResultsDatabaseError, match="no folder"):
        ResultsDatabase(tmp_path / "a-file" / "results.sqlite")


@pytest.fixture(params=["sqlite", "postgresql"])
def location(request, tmp_path: Path) -> str | Path:
    """A new results database on each back end: an SQLite file, a PostgreSQL database."""
    if request.param == "sqlite":
        return tmp_path / "results.sqlite"
    return request.getfixturevalue("postgres_url")


def test_postgres_database_is_migrated_once(postgres_url: str) -> None:
    with ResultsDatabase(postgres_url) as db:
        assert db.schema_version == SCHEMA_VERSION and db.integrity_check() == "ok"
        assert "postgresql" in db.name
    with ResultsDatabase(postgres_url) as db:  # a second open finds it migrated
        rows = db._con.execute("SELECT version FROM schema_migrations ORDER BY version").fetchall()
        assert [r[0] for r in rows] == list(range(1, SCHEMA_VERSION + 1))
        kinds = dict(db._con.execute(  # figures keep double precision, as in SQLite
            "SELECT column_name, data_type FROM information_schema.columns"
            " WHERE table_name = 'figures'"
        ).fetchall())
        assert kinds["value"] == kinds["ci_low"] == "double precision"


def test_unreachable_server_is_one_line_error(tmp_path: Path) -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # nobody listens there once closed
    url = f"postgresql://station:secret@127.0.0.1:{port}/results"
    with pytest.raises(ResultsDatabaseError, match="cannot open the results database") as info:
        ResultsDatabase(url)
    assert "secret" not in str(info.value) and "***" in str(info.value)
    assert main(["results", "--db", url]) == 2


@pytest.fixture()
def filled(location, setup) -> str | Path:
    graded = setup[2]
    path = location
    with ResultsDatabase(path) as db:
        db.store(_variant(graded, "S1", "L1", "2026-03-01T10:00:00Z", "A"))
        db.store(_variant(graded, "S2", "L1", "2026-03-02T10:00:00Z", "reject"))
        db.store(_variant(graded, "S3", "L2", "2026-04-01T10:00:00Z", "indeterminate"))
        db.store(_variant(graded, "S2", "L1", "2026-03-05T10:00:00Z", "B"))  # S2 re-tested: passes
    return path


def test_filters_yield_and_trend(filled, tmp_path: Path) -> None:
    with ResultsDatabase(filled) as db:
        assert len(db.gradings()) == 4
        assert {r.serial_number for r in db.gradings(lot="L1")} == {"S1", "S2"}
        assert [r.serial_number for r in db.gradings(verdict="fail")] == ["S2"]
        assert [r.serial_number for r in db.gradings(since="2026-04-01")] == ["S3"]
        assert [r.serial_number for r in db.gradings(until="2026-03-01")] == ["S1"]
        assert db.gradings(model="TG-1") and not db.gradings(model="other")
        assert [r.grade for r in db.gradings(serial="S2", latest=True)] == ["B"]
        by_lot = {y.lot: y for y in db.yield_by_lot()}
        assert (by_lot["L1"].total, by_lot["L1"].passed, by_lot["L1"].yield_fraction) == (2, 2, 1.0)
        assert (by_lot["L2"].total, by_lot["L2"].indeterminate, by_lot["L2"].yield_fraction) == (
            1,
            1,
            0.0,
        )
        trend = db.trend("arw", axis="x")
        assert [p.serial_number for p in trend] == ["S1", "S2", "S2", "S3"]
        assert all(p.unit == "deg/sqrt(h)" and p.ci_low <= p.value <= p.ci_high for p in trend)
        grading_id = db.gradings()[0].id
        names = {r["name"] for r in db.figures(grading_id)}
        assert names == {"arw", "bias_instability", "bias_stability_10s", "bias"}
        names = "arw, bias, bias_instability, bias_stability_10s"
        with pytest.raises(UsageError, match=f"no figure 'nonsense' in the results database; "
                                             f"its figures: {names}"):
            db.trend("nonsense")
        rows = export_csv(db.gradings(), tmp_path / "all.csv")
    with rows.open() as fh:
        table = list(csv.DictReader(fh))
    assert len(table) == 4 and table[0]["serial_number"] == "S1" and table[0]["grade"] == "A"


def test_results_command(filled, tmp_path: Path, capsys) -> None:
    assert (
        main(["results", "--db", str(filled), "--lot", "L1", "--csv", str(tmp_path / "l1.csv")])
        == 0
    )
    out = capsys.readouterr().out
    assert "S1" in out and "S3" not in out and "3 gradings" in out
    assert len((tmp_path / "l1.csv").read_text().splitlines()) == 4
    assert main(["results", "--db", str(filled), "--yield"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"L1\s+TG-1\s+2\s+2\s+0\s+0\s+100\.0 %", out)
    png = tmp_path / "trend.png"
    assert main(["results", "--db", str(filled), "--trend", "arw", "--png", str(png)]) == 0
    assert "arw [deg/sqrt(h)]" in capsys.readouterr().out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


def test_report_files_are_recorded(setup, tmp_path: Path, capsys) -> None:
    record, profile, _ = setup
    db = tmp_path / "r.sqlite"
    assert (
        main(["grade", str(record), "--profile", str(profile), "--db", str(db), "--lot", "L9"]) == 0
    )
    assert (
        main(
            [
                "report",
                str(record),
                "--profile",
                str(profile),
                "--db",
                str(db),
                "--format",
                "csv",
                "--out",
                str(tmp_path / "out"),
            ]
        )
        == 0
    )
    capsys.readouterr()
    with ResultsDatabase(db) as results:
        rows = results.gradings()
        assert len(rows) == 1 and rows[0].lot == "L9"  # the report joined the stored grading
        reports = results.reports(rows[0].id)
    assert [r["format"] for r in reports] == ["csv"] and Path(reports[0]["path"]).exists()


WRITER = """
import os, pickle, sys, time
from dataclasses import replace
from station.output.results import ResultsDatabase
graded = pickle.load(open(sys.argv[1], "rb"))
run = graded.run
with ResultsDatabase(sys.argv[2]) as db:
    print("ready", flush=True)
    while not os.path.exists(sys.argv[4]):
        time.sleep(0.005)
    start = time.time()
    for i in range(int(sys.argv[3])):  # each a new revision (its lot differs)
        lot = f"{sys.argv[5]}-{i}"
        db.store(replace(graded, run=replace(run, metadata=replace(run.metadata, lot=lot))))
        time.sleep(0.01)  # a station stores a unit now and then, not in a tight loop
    print(start, time.time(), flush=True)
"""


def _writer(pickled: Path, db: str | Path, count: int, go: Path, lot: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen(
        [sys.executable, "-c", WRITER, str(pickled), str(db), str(count), str(go), lot],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


def _pickle(graded: RunGrade, path: Path) -> Path:
    import pickle

    path.write_bytes(pickle.dumps(graded))
    return path


def _check_complete(db: str | Path, n_figures: int) -> int:
    """Every stored grading has all its figure rows; returns the number of gradings."""
    with ResultsDatabase(db) as results:
        assert results.integrity_check() == "ok"
        rows = results.gradings()
        for row in rows:
            assert len(results.figures(row.id)) == n_figures
    return len(rows)


WRITERS = 8
STORES = 25


def _store_many(
    graded: RunGrade, location: str | Path, lot: str, start: object, out: object
) -> None:
    """One station (a forked process): open the database, wait for the start, store ``STORES``
    gradings (each of the same run, unit and profile, with its own lot: the next revision),
    report its write window (or the error that stopped it)."""
    try:
        run = graded.run
        with ResultsDatabase(location) as db:
            start.wait(timeout=60)  # type: ignore[attr-defined]
            t0 = time.time()
            for i in range(STORES):
                metadata = replace(run.metadata, lot=f"{lot}-{i}")
                db.store(replace(graded, run=replace(run, metadata=metadata)))
            out.put((lot, t0, time.time(), ""))  # type: ignore[attr-defined]
    except BaseException as exc:  # the test shows it
        out.put((lot, 0.0, 0.0, f"{type(exc).__name__}: {exc}"))  # type: ignore[attr-defined]


def test_eight_processes_write_at_once(setup, location, tmp_path: Path) -> None:
    """Eight stations open one new database and store gradings into it at the same instant:
    each creates and migrates it, none fails ("database is locked", a unique key, a
    deadlock), no row is lost, the unit, run and profile they share are stored once, and
    the revisions of their grading are numbered 1 to 200 without a gap or a double."""
    import multiprocessing

    graded = setup[2]
    ctx = multiprocessing.get_context("fork")  # the gradings' classes are already imported
    start, out = ctx.Barrier(WRITERS + 1), ctx.Queue()
    lots = [f"P{i}" for i in range(WRITERS)]
    procs = [
        ctx.Process(target=_store_many, args=(graded, location, lot, start, out)) for lot in lots
    ]
    for p in procs:
        p.start()
    try:
        start.wait(timeout=60)  # every writer has its connection: go
    except threading.BrokenBarrierError:
        raise AssertionError(
            f"a writer failed to open the database: {out.get(timeout=10)}"
        ) from None
    reports = [out.get(timeout=180) for _ in procs]
    for p in procs:
        p.join(timeout=60)
    assert [error for *_, error in reports if error] == []
    assert max(t0 for _, t0, _, _ in reports) < min(t1 for _, _, t1, _ in reports), (
        "the writers did not all write at the same time"
    )
    assert _check_complete(location, len(graded.profile.figures)) == WRITERS * STORES
    with ResultsDatabase(location) as results:
        rows = results.gradings()
        shared = [
            results._con.execute(f"SELECT COUNT(*) FROM {t}").fetchone()[0]
            for t in ("profiles", "runs", "units")
        ]
    assert sorted(r.lot for r in rows) == sorted(f"{lot}-{i}" for lot in lots
                                                 for i in range(STORES))
    assert sorted(r.revision for r in rows) == list(range(1, WRITERS * STORES + 1))
    assert shared == [1, 1, 1]


def test_killed_writer_leaves_a_sound_database(setup, tmp_path: Path) -> None:
    graded = setup[2]
    pickled = _pickle(graded, tmp_path / "graded.pickle")
    db = tmp_path / "killed.sqlite"
    go = tmp_path / "go"
    go.touch()
    proc = _writer(pickled, db, 100_000, go, "K")
    assert proc.stdout is not None and proc.stdout.readline().strip() == "ready"
    deadline = time.monotonic() + 60
    with ResultsDatabase(db) as watcher:  # kill it mid-way through its writes
        while len(watcher.gradings()) < 20 and time.monotonic() < deadline:
            time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    n = _check_complete(db, len(graded.profile.figures))
    assert 20 <= n < 100_000
    with ResultsDatabase(db) as results:  # and it takes new writes
        results.store(graded)
    assert _check_complete(db, len(graded.profile.figures)) == n + 1
