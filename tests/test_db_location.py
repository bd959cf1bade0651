"""A ``--db`` that cannot be a results database (an unknown URL scheme, a folder that does
not exist, a file that is not a database, a folder) is refused at once in one line, exit 2,
nothing created; only a database that exists and stops answering is waited for."""

from __future__ import annotations

import sqlite3
import time
from pathlib import Path

import pytest
from starlette.testclient import TestClient

from station.cli import main
from station.evaluation.grading import RunGrade
from station.output.results import ResultsDatabase
from station.output.results_backends import DatabaseLocationError
from station.output.results_queue import StoreQueue
from station.web import ServeConfig, create_app
from tests.test_grading import make_record, profile_text, write_profile
from tests.test_production_stats import graded  # noqa: F401  (a fixture)


def _mistyped(tmp_path: Path) -> dict[str, str]:
    (tmp_path / "notes.txt").write_text("the line's notes, not a database\n")
    (tmp_path / "folder").mkdir()
    return {"scheme": "postgresq://station:secret@127.0.0.1/results",
            "no folder": str(tmp_path / "nonexistent" / "dir" / "results.db"),
            "text file": str(tmp_path / "notes.txt"),
            "folder": str(tmp_path / "folder")}


def _exit_status(args: list[str]) -> int:
    """``station ARGS``'s exit status (argparse's refusals exit through SystemExit)."""
    try:
        return main(args)
    except SystemExit as exc:
        return int(exc.code or 0)


def _tree(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


@pytest.mark.parametrize("command", ["grade", "results", "serve"])
def test_a_mistyped_db_is_refused_at_once_in_one_line(command: str, tmp_path: Path,
                                                      monkeypatch, capsys) -> None:
    work = tmp_path / "work"
    work.mkdir()
    record = make_record(tmp_path / "unit.csv", n=2_000, seed=3)
    profile = write_profile(tmp_path, profile_text(warmup_s=10.0))
    mistyped = _mistyped(work)
    monkeypatch.chdir(work)  # a relative folder "postgresq:" would be made here
    before = _tree(work)
    for case, db in mistyped.items():
        args = {"grade": ["grade", str(record), "--profile", str(profile), "--db", db],
                "results": ["results", "--db", db],
                "serve": ["serve", "--db", db, "--port", "1"]}[command]
        start = time.monotonic()
        assert _exit_status(args) == 2, case
        assert time.monotonic() - start < 5.0, case  # not waited for as an outage
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--db" in err[0], (case, err)
        assert "secret" not in err[0]
    assert _tree(work) == before  # nothing created, the text file as it was
    assert (work / "notes.txt").read_text() == "the line's notes, not a database\n"
    assert not Path("/nonexistent").exists()


def test_a_file_of_something_else_is_no_outage(graded: RunGrade, tmp_path: Path  # noqa: F811
                                               ) -> None:
    mistyped = _mistyped(tmp_path)
    other = tmp_path / "other.sqlite"  # an SQLite file of another program
    con = sqlite3.connect(other)
    con.execute("CREATE TABLE parts (id INTEGER PRIMARY KEY, name TEXT)")
    con.commit()
    con.close()
    for db in (mistyped["text file"], mistyped["folder"], mistyped["no folder"], str(other)):
        with pytest.raises(DatabaseLocationError):
            ResultsDatabase(Path(db))
        queue = StoreQueue(Path(db), retry_s=30.0)
        start = time.monotonic()
        with pytest.raises(DatabaseLocationError):
            queue.put("run", graded)
        assert time.monotonic() - start < 2.0 and queue.waiting == 1
    assert not (tmp_path / "nonexistent").exists()
    assert sqlite3.connect(other).execute("SELECT name FROM sqlite_master").fetchall() == [
        ("parts",)]
    # an empty file is a new database, made a results database by the first store
    empty = tmp_path / "empty.sqlite"
    empty.write_bytes(b"")
    with ResultsDatabase(empty) as db:
        assert db.store(graded) and len(db.gradings()) == 1


def test_serve_reads_an_empty_server_database_as_empty(postgres_url: str) -> None:
    import psycopg

    client = TestClient(create_app(ServeConfig(postgres_url)))
    assert client.get("/api/overview").json()["lots"] == []
    assert client.get("/api/stats").json()["units"] == 0
    with psycopg.connect(postgres_url) as con:  # no schema made: nothing was written
        assert con.execute("SELECT COUNT(*) FROM pg_catalog.pg_tables"
                           " WHERE schemaname = current_schema()").fetchone() == (0,)
