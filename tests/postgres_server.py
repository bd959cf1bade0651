"""A real PostgreSQL server for the test session, on 127.0.0.1 and a free port.

The server is Debian's PostgreSQL 15 (``/usr/lib/postgresql/15/bin``, or ``$STATION_PG_BIN``).
It refuses to run as root, so as root (CI) ``initdb`` and ``pg_ctl`` run as the ``postgres``
system user through ``runuser``; the data directory is a fresh temporary directory owned
by that user. Each test that asks for :func:`postgres_url` gets a database of its own.
The tests skip only where the server's binaries are not installed.
"""

from __future__ import annotations

import itertools
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest

PG_BIN = Path(os.environ.get("STATION_PG_BIN", "/usr/lib/postgresql/15/bin"))
_names = itertools.count(1)


@dataclass(frozen=True)
class PostgresServer:
    """A running server: where it listens and how to reach its maintenance database."""

    host: str
    port: int
    data_dir: Path
    #: The server's options and log file, to start it again after :meth:`stop`.
    options: str = ""
    log: Path | None = None

    def url(self, database: str = "postgres") -> str:
        """Connection URL of ``database`` (trust authentication, user ``postgres``)."""
        return f"postgresql://postgres@{self.host}:{self.port}/{database}"

    def stop(self) -> None:
        """Stop the server at once (an outage: connections are cut, new ones refused)."""
        _pg_ctl(self.data_dir, "-m", "immediate", "-w", "stop")

    def start(self) -> None:
        """Start the server again (after :meth:`stop`), on the same port and data."""
        _pg_ctl(self.data_dir, "-l", str(self.log), "-o", self.options, "-w", "-t", "60",
                "start")

    def create_database(self) -> str:
        """A new, empty database; its URL."""
        import psycopg

        name = f"station_test_{os.getpid()}_{next(_names)}"
        with psycopg.connect(self.url(), autocommit=True) as con:
            con.execute(f'CREATE DATABASE "{name}"')
        return self.url(name)


def _pg_ctl(data: Path, *args: str) -> None:
    result = subprocess.run([*_as_postgres(), str(PG_BIN / "pg_ctl"), "-D", str(data), *args],
                            capture_output=True, text=True, timeout=120)
    if result.returncode != 0:
        raise RuntimeError(f"pg_ctl {' '.join(args)} failed: {result.stderr}{result.stdout}")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _as_postgres() -> list[str]:
    """The prefix that runs a command as the ``postgres`` user when we are root."""
    if os.geteuid() != 0:
        return []
    if shutil.which("runuser") is None:
        raise RuntimeError("running as root without runuser: cannot start PostgreSQL as postgres")
    return ["runuser", "-u", "postgres", "--"]


@pytest.fixture(scope="session")
def postgres_server() -> Iterator[PostgresServer]:
    """Start a PostgreSQL server for the session (stopped and removed at its end)."""
    if not (PG_BIN / "initdb").exists() or not (PG_BIN / "pg_ctl").exists():
        pytest.skip(
            f"PostgreSQL server binaries not installed in {PG_BIN} (apt install postgresql-15)"
        )
    with running_server() as server:
        yield server


@contextmanager
def running_server() -> Iterator[PostgresServer]:
    """A PostgreSQL server in a fresh temporary directory (stopped and removed after)."""
    prefix = _as_postgres()
    root = Path(tempfile.mkdtemp(prefix="station-pg-"))
    data = root / "data"
    if prefix:
        user = pwd.getpwnam("postgres")
        os.chown(root, user.pw_uid, user.pw_gid)
    port = _free_port()
    log = root / "server.log"

    def run(*command: str) -> None:
        result = subprocess.run([*prefix, *command], capture_output=True, text=True, timeout=120)
        if result.returncode != 0:
            server_log = log.read_text() if log.exists() else ""
            raise RuntimeError(
                f"{' '.join(command)} failed: {result.stderr}{result.stdout}{server_log}"
            )

    run(
        str(PG_BIN / "initdb"),
        "-D",
        str(data),
        "-U",
        "postgres",
        "--auth=trust",
        "-E",
        "UTF8",
        "--no-sync",
    )
    options = (
        f"-c listen_addresses=127.0.0.1 -p {port} -k {data} -c fsync=off -c max_connections=60"
    )
    run(
        str(PG_BIN / "pg_ctl"),
        "-D",
        str(data),
        "-l",
        str(log),
        "-o",
        options,
        "-w",
        "-t",
        "60",
        "start",
    )
    try:
        yield PostgresServer("127.0.0.1", port, data, options, log)
    finally:
        subprocess.run(
            [*prefix, str(PG_BIN / "pg_ctl"), "-D", str(data), "-m", "immediate", "-w", "stop"],
            capture_output=True,
            timeout=60,
        )
        shutil.rmtree(root, ignore_errors=True)


@pytest.fixture()
def postgres_url(postgres_server: PostgresServer) -> str:
    """URL of a fresh, empty database on the session's server."""
    return postgres_server.create_database()
