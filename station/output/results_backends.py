"""Where the results database lives: an SQLite file (the embedded default) or a PostgreSQL
server (``postgresql://user@host/db``, through psycopg 3), behind one small connection type.

The results database writes its SQL once, with ``?`` placeholders and the SQL both engines
share; a :class:`Backend` runs it, holds the write transaction, records the schema version
and turns SQLite's DDL into PostgreSQL's where the two differ (:func:`postgres_ddl`).

Concurrency: SQLite writers take the file's write lock (``BEGIN IMMEDIATE``, WAL journal,
a busy timeout); PostgreSQL writers run in READ COMMITTED transactions, and the few
statements two stations may race on are ``INSERT ... ON CONFLICT DO NOTHING``. A transaction
the server aborts as a deadlock or a serialization failure is retried by the caller
(:attr:`Backend.retryable`); migrations are serialized by an advisory lock.
"""

from __future__ import annotations

import os
import re
import sqlite3
from collections.abc import Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path
from typing import Any, Protocol
from urllib.parse import urlsplit, urlunsplit

from station.errors import ResultsDatabaseError, UsageError

#: Environment variable naming the results database (a file or a PostgreSQL URL).
DB_ENV = "STATION_RESULTS_DB"
#: A results database: an SQLite file, or a PostgreSQL connection URL.
DatabaseLocation = str | Path
URL_SCHEMES = ("postgresql", "postgres")
BUSY_TIMEOUT_S = 60.0
#: Key of the PostgreSQL advisory lock held while the schema is migrated ("gyro-db").
MIGRATION_LOCK_KEY = 0x6779726F2D6462
#: How many times a write aborted by the server (deadlock, serialization) is tried.
WRITE_ATTEMPTS = 8
#: How long an outage of the results database is waited for, by default, s
#: (:class:`station.output.results_queue.StoreQueue`).
STORE_RETRY_S = 30.0


#: The first 16 bytes of every SQLite database file ("Database File Format", sqlite.org,
#: section 1.3: the header string).
SQLITE_HEADER = b"SQLite format 3\x00"


class DatabaseLocationError(UsageError, ResultsDatabaseError):
    """A ``--db`` that cannot mean a results database: an unknown URL scheme, a folder, a
    file that is not one, a folder to put it in that does not exist. Refused at once, never
    waited for as an outage."""


def is_database_url(location: DatabaseLocation) -> bool:
    """Whether ``location`` is a PostgreSQL URL rather than an SQLite file path."""
    return isinstance(location, str) and urlsplit(location).scheme in URL_SCHEMES


def database_location(text: str) -> DatabaseLocation:
    """``--db`` text as a location: a PostgreSQL URL stays text, anything else is a path.

    Raises
    ------
    DatabaseLocationError
        ``text`` is a URL (``scheme://``) of a scheme other than PostgreSQL's.
    """
    if is_database_url(text):
        return text
    if "://" in text:
        raise DatabaseLocationError(
            f"{redacted(text)}: unknown database URL scheme "
            f"{urlsplit(text).scheme or text.split('://', 1)[0]!r}: give postgresql://USER@HOST/DB "
            "or an SQLite file")
    if not text.strip():
        raise DatabaseLocationError("an empty --db: give an SQLite file or a postgresql:// URL")
    return Path(text)


def check_database_file(path: Path, *, create_folder: bool = False) -> None:
    """Refuse an SQLite location that cannot be a results database, touching nothing.

    A file that exists must be an SQLite database (its header, :data:`SQLITE_HEADER`) or
    empty; a file that does not exist yet needs its folder (made first when
    ``create_folder``: the default database's).

    Raises
    ------
    DatabaseLocationError
        ``path`` is a folder, a file that is no SQLite database, or sits in a folder that
        does not exist (or is a file).
    """
    if path.is_dir():
        raise DatabaseLocationError(f"{path} is a folder: give the results database's file "
                                    f"(e.g. {path / 'results.sqlite'})")
    if path.exists():
        try:
            with path.open("rb") as f:
                head = f.read(len(SQLITE_HEADER))
        except OSError as exc:
            raise DatabaseLocationError(f"cannot read {path}: {exc.strerror or exc}") from exc
        if head and head != SQLITE_HEADER:
            raise DatabaseLocationError(f"{path} is not a results database (not an SQLite "
                                        "file): give the database's file or a new name")
        return
    folder = path.parent
    if create_folder and not folder.exists():
        return
    if not folder.is_dir():
        raise DatabaseLocationError(f"no folder {folder} for the results database "
                                    f"{path.name}: create it first, or give another --db")


def redacted(location: DatabaseLocation) -> str:
    """The location for messages: a URL's password replaced by ``***``."""
    if not isinstance(location, str) or "://" not in location:
        return str(location)
    parts = urlsplit(str(location))
    if parts.password is None:
        return str(location)
    netloc = parts.netloc.replace(f":{parts.password}@", ":***@", 1)
    return urlunsplit(parts._replace(netloc=netloc))


def database_exists(location: DatabaseLocation) -> bool:
    """Whether there is a database to read: the SQLite file exists (a server always counts)."""
    return is_database_url(location) or Path(location).exists()


class Cursor(Protocol):
    """What the results database reads from a statement."""

    def fetchone(self) -> Any: ...

    def fetchall(self) -> list[Any]: ...


class Backend(Protocol):
    """A connection to one results database, as :class:`station.results.ResultsDatabase` uses it."""

    #: Errors after which a whole write transaction may be tried again.
    retryable: tuple[type[BaseException], ...]
    #: Every error the driver raises (reported as :class:`ResultsDatabaseError`).
    errors: tuple[type[BaseException], ...]
    #: The location, for messages (no password).
    name: str

    def execute(self, sql: str, params: Sequence[object] = ()) -> Cursor:
        """Run one statement (``?`` placeholders)."""
        ...

    def transaction(self) -> AbstractContextManager[None]:
        """One write transaction: committed whole, or rolled back."""
        ...

    def schema_version(self) -> int:
        """The schema version the database was migrated to (0: a new database)."""
        ...

    def lock(self, key: str) -> None:
        """Inside a write transaction: wait until no other writer holds ``key``, and hold
        it until the transaction ends (two stations numbering one grading's revisions)."""
        ...

    def migration(self) -> AbstractContextManager[None]:
        """A write transaction during which no other station migrates."""
        ...

    def run_ddl(self, script: str) -> None:
        """Run one migration's statements (inside :meth:`migration`)."""
        ...

    def set_schema_version(self, version: int) -> None:
        """Record the version a migration reached (inside :meth:`migration`)."""
        ...

    def integrity_check(self) -> str:
        """``"ok"`` when the database is sound, else what is wrong."""
        ...

    def has_tables(self) -> bool:
        """Whether the database holds any table (of this schema or another)."""
        ...

    def close(self) -> None:
        """Close the connection."""
        ...


def _statements(script: str) -> Iterator[str]:
    return (s for s in script.split(";") if s.strip())


class SqliteBackend:
    """An SQLite file in WAL mode with a busy timeout; writes are ``BEGIN IMMEDIATE``."""

    retryable: tuple[type[BaseException], ...] = ()
    errors: tuple[type[BaseException], ...] = (sqlite3.Error,)

    def __init__(self, path: Path, *, create_folder: bool = False,
                 read_only: bool = False) -> None:
        self.name = str(path)
        check_database_file(path, create_folder=create_folder)
        try:
            if read_only:
                # mode=ro: nothing is written, not even the schema of an empty file
                uri = f"{path.resolve().as_uri()}?mode=ro"
                self._con = sqlite3.connect(uri, uri=True, timeout=BUSY_TIMEOUT_S,
                                            isolation_level=None, check_same_thread=False)
            else:
                if create_folder:
                    path.parent.mkdir(parents=True, exist_ok=True)
                self._con = sqlite3.connect(path, timeout=BUSY_TIMEOUT_S, isolation_level=None)
        except (OSError, sqlite3.Error) as exc:
            raise ResultsDatabaseError(f"cannot open the results database {path}: {exc}") from exc
        try:
            self._con.row_factory = sqlite3.Row
            if not read_only:
                self._con.execute("PRAGMA journal_mode=WAL")
                self._con.execute("PRAGMA synchronous=NORMAL")
            self._con.execute("PRAGMA foreign_keys=ON")
        except sqlite3.DatabaseError as exc:
            self._con.close()
            raise ResultsDatabaseError(f"{path}: {exc}") from exc

    @classmethod
    def in_memory(cls) -> SqliteBackend:
        """A new database held in memory (an empty results database to read)."""
        backend = cls.__new__(cls)
        backend.name = ":memory:"
        backend._con = sqlite3.connect(":memory:", isolation_level=None,
                                       check_same_thread=False)
        backend._con.row_factory = sqlite3.Row
        return backend

    def has_tables(self) -> bool:
        """Whether the file holds any table (an SQLite file of something else does)."""
        return self._con.execute("SELECT COUNT(*) FROM sqlite_master WHERE type = 'table'"
                                 ).fetchone()[0] > 0

    def execute(self, sql: str, params: Sequence[object] = ()) -> sqlite3.Cursor:
        """Run one statement."""
        return self._con.execute(sql, tuple(params))

    @contextmanager
    def transaction(self) -> Iterator[None]:
        """``BEGIN IMMEDIATE`` ... ``COMMIT`` (``ROLLBACK`` on any exception)."""
        self._con.execute("BEGIN IMMEDIATE")
        try:
            yield
        except BaseException:
            self._con.execute("ROLLBACK")
            raise
        self._con.execute("COMMIT")

    def lock(self, key: str) -> None:
        """Nothing: ``BEGIN IMMEDIATE`` already keeps every other writer out."""

    def schema_version(self) -> int:
        """``PRAGMA user_version``."""
        return int(self._con.execute("PRAGMA user_version").fetchone()[0])

    def migration(self) -> AbstractContextManager[None]:
        """The write transaction itself: ``BEGIN IMMEDIATE`` already keeps other writers out."""
        return self.transaction()

    def run_ddl(self, script: str) -> None:
        """Each statement of the script, in the open transaction."""
        for statement in _statements(script):
            self._con.execute(statement)

    def set_schema_version(self, version: int) -> None:
        """``PRAGMA user_version = version``."""
        self._con.execute(f"PRAGMA user_version = {int(version)}")

    def integrity_check(self) -> str:
        """SQLite's ``PRAGMA integrity_check`` answer."""
        return str(self._con.execute("PRAGMA integrity_check").fetchone()[0])

    def close(self) -> None:
        """Close the connection."""
        self._con.close()


#: SQLite spellings and what PostgreSQL says for them, applied to the migrations in order.
_POSTGRES_DDL: tuple[tuple[str, str], ...] = (
    (r"\bid INTEGER PRIMARY KEY\b", "id INTEGER GENERATED BY DEFAULT AS IDENTITY PRIMARY KEY"),
    (r"\bREAL\b", "DOUBLE PRECISION"),  # REAL is 4 bytes in PostgreSQL, 8 in SQLite
    (r"ON (\w+) \(([^()]*!=[^()]*)\)", r"ON \1 ((\2))"),  # an index on an expression
)


def postgres_ddl(script: str) -> str:
    """A migration written for SQLite in PostgreSQL's spelling (same tables, columns, indexes)."""
    for pattern, replacement in _POSTGRES_DDL:
        script = re.sub(pattern, replacement, script)
    return script


class Row(tuple):
    """A result row read by position or by column name (as :class:`sqlite3.Row` is)."""

    _names: tuple[str, ...] = ()

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, str):
            try:
                key = self._names.index(key)
            except ValueError:
                raise IndexError(f"no column {key!r}") from None
        return tuple.__getitem__(self, key)

    def keys(self) -> list[str]:
        """The column names."""
        return list(self._names)


def _row_factory(cursor: Any) -> Any:
    names = tuple(c.name for c in cursor.description or ())

    def make(values: Sequence[Any]) -> Row:
        row = Row(values)
        row._names = names
        return row

    return make


class PostgresBackend:
    """A PostgreSQL database through psycopg 3 (autocommit; explicit transactions)."""

    def __init__(self, url: str, *, read_only: bool = False) -> None:
        import psycopg  # only a station that names a server needs the driver
        from psycopg import errors

        self.name = redacted(url)
        self._psycopg = psycopg
        self.retryable: tuple[type[BaseException], ...] = (
            errors.DeadlockDetected,
            errors.SerializationFailure,
        )
        self.errors: tuple[type[BaseException], ...] = (psycopg.Error,)
        timeout = os.environ.get("PGCONNECT_TIMEOUT", "10")
        try:
            self._con = psycopg.connect(
                url, autocommit=True, row_factory=_row_factory, connect_timeout=int(timeout)
            )
        except (psycopg.Error, ValueError) as exc:
            raise ResultsDatabaseError(
                f"cannot open the results database {self.name}: {str(exc).strip().splitlines()[0]}"
            ) from exc
        if read_only:
            try:
                self._con.execute("SET SESSION CHARACTERISTICS AS TRANSACTION READ ONLY")
            except psycopg.Error as exc:
                self._con.close()
                raise ResultsDatabaseError(f"{self.name}: {exc}") from exc

    def has_tables(self) -> bool:
        """Whether the schema holds any table."""
        return bool(self.execute("SELECT COUNT(*) FROM pg_catalog.pg_tables"
                                 " WHERE schemaname = current_schema()").fetchone()[0])

    def execute(self, sql: str, params: Sequence[object] = ()) -> Any:
        """Run one statement; ``?`` placeholders become psycopg's ``%s``."""
        return self._con.execute(sql.replace("%", "%%").replace("?", "%s"), tuple(params))

    @contextmanager
    def transaction(self) -> Iterator[None]:
        """``BEGIN`` ... ``COMMIT`` (rolled back on any exception)."""
        with self._con.transaction():
            yield

    def schema_version(self) -> int:
        """The highest version in ``schema_migrations`` (0 when the table is not there).

        The table is looked up in ``pg_tables`` under the statement's own snapshot: the
        server's catalog cache (``to_regclass``) may not yet show a table another station
        created while this one waited for the migration lock.
        """
        if not self.execute(
            "SELECT COUNT(*) FROM pg_catalog.pg_tables WHERE tablename ="
            " 'schema_migrations' AND schemaname = current_schema()"
        ).fetchone()[0]:
            return 0
        return int(
            self.execute("SELECT COALESCE(MAX(version), 0) FROM schema_migrations").fetchone()[0]
        )

    def lock(self, key: str) -> None:
        """A transaction-level advisory lock on the key's hash."""
        self.execute("SELECT pg_advisory_xact_lock(hashtext(?))", (key,))

    @contextmanager
    def migration(self) -> Iterator[None]:
        """A transaction holding the migration advisory lock until it ends."""
        with self.transaction():
            self.execute("SELECT pg_advisory_xact_lock(?)", (MIGRATION_LOCK_KEY,))
            yield

    def run_ddl(self, script: str) -> None:
        """Each statement of the script in PostgreSQL's spelling (:func:`postgres_ddl`)."""
        for statement in _statements(postgres_ddl(script)):
            self._con.execute(statement)

    def set_schema_version(self, version: int) -> None:
        """Nothing: ``schema_migrations`` is the record."""

    def integrity_check(self) -> str:
        """``"ok"`` when every table of the schema answers (the server keeps its own pages)."""
        try:
            for table in (
                "profiles",
                "runs",
                "units",
                "gradings",
                "axis_grades",
                "figures",
                "reports",
            ):
                self.execute(f"SELECT COUNT(*) FROM {table}").fetchone()
        except self._psycopg.Error as exc:
            return str(exc).strip()
        return "ok"

    def close(self) -> None:
        """Close the connection."""
        self._con.close()


def open_backend(location: DatabaseLocation, *, create_folder: bool = False,
                 read_only: bool = False) -> Backend:
    """A connection to the database at ``location`` (URL: PostgreSQL; else an SQLite file).

    ``create_folder``: an SQLite file's folder is made when missing (the default
    database's); ``read_only``: nothing is ever written (``station serve``).

    Raises
    ------
    DatabaseLocationError
        ``location`` cannot be a results database (:func:`check_database_file`).
    ResultsDatabaseError
        The file or server cannot be opened.
    """
    if is_database_url(location):
        return PostgresBackend(str(location), read_only=read_only)
    if isinstance(location, str) and "://" in location:
        database_location(location)  # refuses the unknown scheme
    return SqliteBackend(Path(location), create_folder=create_folder, read_only=read_only)
