"""Storing gradings while the results database may be away for a while.

A store is tried at once. One that fails (the server stopped or unreachable, the file
locked or its disk full) is kept and tried again with back-off (0.25 s, doubled up to 4 s
between tries), on a new connection, while the caller goes on (a fleet grades its other
runs meanwhile). An outage is waited for at most ``retry_s`` seconds from its first failed
store; a grading still not stored then is listed with the last error (:class:`NotStored`)
and the caller says so. Storing is idempotent (:mod:`station.output.results_store`): a
store whose commit reached the server but whose answer was lost, tried again, stores
nothing twice. A unit whose serial is another unit's (:class:`SerialConflictError`) is
listed at once: trying again would not change it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from station.errors import ResultsDatabaseError, SerialConflictError
from station.output.results import ResultsDatabase
from station.output.results_backends import STORE_RETRY_S, DatabaseLocation, DatabaseLocationError
from station.output.results_store import ReportFile

if TYPE_CHECKING:
    from station.evaluation.grading import RunGrade

__all__ = ["STORE_RETRY_S", "NotStored", "StoreQueue"]

#: The first wait between two tries of a failed store, s (doubled after each failure).
FIRST_BACKOFF_S = 0.25
#: The longest wait between two tries, s.
MAX_BACKOFF_S = 4.0


@dataclass(frozen=True)
class NotStored:
    """A run whose grading is not in the results database: its file, the units graded,
    and why (the last error)."""

    file: str
    units: tuple[str, ...]
    error: str
    #: Refused for a serial another unit has (:class:`SerialConflictError`), not tried again.
    conflict: bool = False

    def as_json(self) -> dict[str, object]:
        """``{"file", "units", "error"}``."""
        return {"file": self.file, "units": list(self.units), "error": self.error}


@dataclass
class _Pending:
    key: str
    graded: RunGrade
    reports: tuple[ReportFile, ...]
    join: bool
    error: str = ""


class StoreQueue:
    """Gradings on their way into one results database (see the module's docstring).

    Parameters
    ----------
    location : str or Path
        The results database.
    retry_s : float
        How long an outage is waited for from its first failed store, s (0: one try).
    clock, sleep : callables
        The monotonic clock (s) and the sleep the back-off uses.
    """

    def __init__(self, location: DatabaseLocation, *, retry_s: float = STORE_RETRY_S,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        if retry_s < 0:
            raise ValueError(f"retry_s must be >= 0 s, not {retry_s}")
        self.location, self.retry_s = location, retry_s
        self._clock, self._sleep = clock, sleep
        self._db: ResultsDatabase | None = None
        self._pending: list[_Pending] = []
        self._refused: list[NotStored] = []
        self._outage_since: float | None = None
        self._backoff_s = FIRST_BACKOFF_S
        self._next_try = 0.0
        self._last_error = ""
        #: The grading ids of each run stored, by its key.
        self.stored: dict[str, list[int]] = {}

    def open(self) -> ResultsDatabase:
        """The connection, opened (and the schema migrated) when there is none.

        Raises
        ------
        ResultsDatabaseError
            The database cannot be opened.
        """
        if self._db is None:
            self._db = ResultsDatabase(self.location)
        return self._db

    def close(self) -> None:
        """Close the connection (what is pending stays pending)."""
        if self._db is not None:
            self._db.close()
            self._db = None

    def __enter__(self) -> StoreQueue:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def waiting(self) -> int:
        """Runs whose store failed and will be tried again."""
        return len(self._pending)

    def put(self, key: str, graded: RunGrade, reports: tuple[ReportFile, ...] = (), *,
            join: bool = False) -> None:
        """Store a run's grading (and its report files) now, or keep it for a later try
        (``join``: see :meth:`ResultsDatabase.store`)."""
        self._pending.append(_Pending(key, graded, reports, join))
        if len(self._pending) == 1 or self._clock() >= self._next_try:
            self._try_pending()

    def poll(self) -> None:
        """Try the kept stores again when their back-off is over (returns at once)."""
        if self._pending and self._clock() >= self._next_try:
            self._try_pending()

    def finish(self) -> list[NotStored]:
        """Try the kept stores until each is stored or the outage has lasted ``retry_s``;
        returns the runs not stored (the refused ones too), in the order they were put."""
        while self._pending:
            self.poll()
            if not self._pending or self._given_up():
                break
            self._sleep(max(0.0, self._next_try - self._clock()))
        lost = self._refused + [NotStored(p.key, _units(p.graded), p.error or self._last_error)
                                for p in self._pending]  # those behind the first: its error
        self._pending.clear()
        return lost

    def _deadline(self) -> float:
        return (self._outage_since or self._clock()) + self.retry_s

    def _given_up(self) -> bool:
        return self._outage_since is not None and self._clock() >= self._deadline()

    def _try_pending(self) -> None:
        while self._pending:
            item = self._pending[0]
            try:
                self.stored[item.key] = self.open().store(item.graded, item.reports,
                                                             join=item.join)
            except SerialConflictError as exc:
                self._pending.pop(0)
                self._refused.append(NotStored(item.key, _units(item.graded), str(exc), True))
                continue
            except DatabaseLocationError:
                raise  # not a database that is away: one that cannot be (a folder, a text file)
            except ResultsDatabaseError as exc:
                item.error = self._last_error = str(exc)
                self.close()  # the next try opens a new connection
                now = self._clock()
                self._outage_since = self._outage_since if self._outage_since is not None \
                    else now
                deadline = self._deadline()  # a last try at the deadline, then on back-off
                self._next_try = (now + self._backoff_s if now >= deadline
                                  else min(now + self._backoff_s, deadline))
                self._backoff_s = min(2 * self._backoff_s, MAX_BACKOFF_S)
                return
            self._pending.pop(0)
            self._outage_since, self._backoff_s = None, FIRST_BACKOFF_S


def _units(graded: RunGrade) -> tuple[str, ...]:
    return tuple(u.unit.unit_id for u in graded.units)
