"""``fleet``: grade, analyse or report many run files at once on a Dask cluster.

One task per (run file, unit) runs on ``dask.distributed``: a :class:`LocalCluster` on this
machine by default (nothing to configure), or any scheduler's address (a real cluster;
docs/fleet.md has the SLURM recipe). Tasks take paths and return small results
(:mod:`station.fleet_tasks`); this driver alone writes the results database and the report
files. A failed task (a corrupt file, a bad profile, a run too short) is listed with its
reason and the others finish. Results are those of ``station grade`` run on each file
(the same numbers in the same JSON document).

Each run is stored as soon as its last unit is back, so a driver stopped half-way keeps
every run it finished. A store the results database does not take (a server stopped) is
tried again with back-off while the other runs go on, and at the end for at most
``db_retry_s``; each run still not stored is listed (``not_stored``). Storing is
idempotent: running the fleet again stores those runs and nothing twice.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from station.errors import StationError, UsageError
from station.evaluation.grading import RunGrade
from station.model.bench import Bench, load_bench
from station.model.profiles import Profile, load_profile
from station.model.version import software_version
from station.output.report import FORMATS, ReportFormat
from station.output.results import default_database_path
from station.output.results_backends import DatabaseLocation
from station.output.results_queue import STORE_RETRY_S, NotStored, StoreQueue
from station.services.fleet_actions import ACTIONS as ACTIONS, LOCAL as LOCAL, FleetAction
from station.services.fleet_tasks import (
    UnitOutcome,
    analyze_task,
    error_text,
    grade_task,
    list_units,
    report_task,
)

#: Suffixes of the run files a directory is searched for.
RUN_SUFFIXES = (".h5", ".hdf5")


#: Times a task may take its worker down with it (killed for memory, a crash in a library)
#: and still be run again on another; the next time it is listed as failed.
WORKER_DEATHS_FORGIVEN = 1


class FleetError(StationError, RuntimeError):
    """The cluster cannot be started or reached."""


def lost_task_text(exc: BaseException) -> str:
    """One line saying why a task's result did not come back: a task whose worker died on
    every try (Dask's ``KilledWorker``; the tries are the scheduler's, which a remote one
    sets itself) says so and where to look; any other error as :func:`error_text` writes it."""
    from distributed import KilledWorker  # imported with the cluster, not with the CLI

    if isinstance(exc, KilledWorker):
        return (
            f"its worker died on each of {exc.allowed_failures + 1} tries (killed for "
            "memory, or a crash in a library): the workers' logs say which"
        )
    return error_text(exc)


@dataclass(frozen=True)
class FleetRequest:
    """What to do to which runs, where.

    Attributes
    ----------
    action : {"grade", "analyze", "report"}
        Grade (and store) each unit; analyse each unit; or grade, store and write the
        spec-sheet reports of each run.
    sources : tuple of str or Path
        Run files (``.h5``, or a CSV record: a run of one unit) and directories (searched
        recursively for ``.h5``/``.hdf5`` files).
    profile : str or None
        The profile to grade with, a name or a TOML file (None: each run's own); loaded
        once here, and sent to the workers whole.
    bench : str, Path or None
        The bench file whose Earth rate the biases are reported without (None: each run's).
    scheduler : str
        ``"local"``: a local cluster of ``workers`` processes; else a scheduler address
        (``tcp://host:8786``).
    workers : int or None
        Worker processes of the local cluster (None: one per CPU).
    db : str, Path or None
        Results database (None: :func:`default_database_path`).
    store : bool
        ``grade``/``report``: store each graded unit.
    formats : tuple of str
        ``report``: the formats (``pdf``, ``html``, ``json``, ``csv``).
    out : Path
        ``report``: where the report files go.
    db_retry_s : float
        How long a results database that is away is waited for (its stores tried again
        with back-off while the fleet goes on, and at its end), s.
    """

    action: FleetAction
    sources: tuple[str | Path, ...]
    profile: str | None = None
    bench: str | Path | None = None
    scheduler: str = LOCAL
    workers: int | None = None
    db: DatabaseLocation | None = None
    store: bool = True
    formats: tuple[ReportFormat, ...] = ("pdf",)
    out: Path = Path(".")
    db_retry_s: float = STORE_RETRY_S

    @property
    def database(self) -> DatabaseLocation:
        """The results database the request names."""
        return self.db if self.db is not None else default_database_path()


@dataclass(frozen=True)
class TaskFailure:
    """A task that failed: the run file, the unit ("" when the file could not be listed or
    its report written) and why."""

    file: str
    unit: str
    error: str

    def as_json(self) -> dict[str, str]:
        """``{"file", "unit", "error"}``."""
        return {"file": self.file, "unit": self.unit, "error": self.error}


@dataclass(frozen=True)
class FleetProgress:
    """Tasks done out of those known so far (the total grows while files are listed)."""

    done: int
    total: int
    elapsed_s: float
    failed: int = 0

    @property
    def eta_s(self) -> float | None:
        """Time left at the rate so far, s (None before the first task is back)."""
        if self.done == 0 or self.total == 0:
            return None
        return self.elapsed_s * (self.total - self.done) / self.done


@dataclass(frozen=True)
class FleetResult:
    """What came back: the graded runs (or each unit's analysis), the failures, and the
    runs graded but not stored (the results database was away, or refused a serial)."""

    action: FleetAction
    tasks: int
    failed: tuple[TaskFailure, ...]
    runs: tuple[RunGrade, ...] = ()
    analyses: tuple[dict[str, object], ...] = ()
    reports: tuple[Path, ...] = ()
    warnings: tuple[str, ...] = ()
    workers: int = 0
    wall_s: float = 0.0
    stored: int = 0
    not_stored: tuple[NotStored, ...] = ()

    @property
    def complete(self) -> bool:
        """Whether every task succeeded and every grading was stored."""
        return not self.failed and not self.not_stored

    def as_json(self) -> dict[str, object]:
        """``{"tasks", "failed": [{"file", "unit", "error"}], "runs": [...], "not_stored":
        [{"file", "units", "error"}]}``: each run the document ``station grade --json``
        prints for it (``analyze``: per unit, the one ``station analyze --json --unit U``
        prints)."""
        runs = [r.as_json() for r in self.runs] if self.action != "analyze" else list(self.analyses)
        out: dict[str, object] = {
            "tasks": self.tasks,
            "failed": [f.as_json() for f in self.failed],
            "runs": runs,
        }
        if self.reports:
            out["reports"] = [str(p) for p in self.reports]
        if self.action != "analyze":
            out["not_stored"] = [n.as_json() for n in self.not_stored]
        out["warnings"] = list(self.warnings)
        return out


ProgressSink = Callable[[FleetProgress], None]


def _ignore(_: FleetProgress) -> None:
    """A sink that shows nothing."""


def run_files(sources: Sequence[str | Path]) -> list[str]:
    """The run files the sources name, in order: files as given, directories searched
    recursively for ``.h5``/``.hdf5`` files (sorted); each file once.

    Raises
    ------
    UsageError
        A source that does not exist, or no run file at all.
    """
    files: list[str] = []
    for source in sources:
        path = Path(source)
        if path.is_dir():
            found = sorted(
                p for p in path.rglob("*") if p.suffix.lower() in RUN_SUFFIXES and p.is_file()
            )
            if not found:
                raise UsageError(f"no run files (.h5) in {path}")
            files += [str(p) for p in found]
        elif path.exists():
            files.append(str(source))
        else:
            raise UsageError(f"no such file or directory: {source}")
    unique: dict[str, str] = {}
    for f in files:
        unique.setdefault(os.path.realpath(f), f)
    return list(unique.values())


def local_workers(workers: int | None) -> int:
    """Worker processes of the local cluster: ``workers``, else one per CPU this process may use."""
    if workers is not None:
        if workers < 1:
            raise UsageError(f"--workers must be at least 1, not {workers}")
        return workers
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def _worker_environ(config: Any) -> dict[str, object]:
    """The environment a local worker starts with: Dask's, without its glibc setting
    ``MALLOC_TRIM_THRESHOLD_``. Setting it fixes malloc's mmap threshold, so every
    array over 128 kB of a grading is a fresh mmap whose pages the kernel zeroes again:
    measured 8 % more CPU per unit graded, and the analysis' memory is bounded by
    itself (the thread limits Dask sets are kept)."""
    environ = dict(config.get("distributed.nanny.pre-spawn-environ", {}) or {})
    environ.pop("MALLOC_TRIM_THRESHOLD_", None)
    return environ


@contextmanager
def cluster_client(scheduler: str = LOCAL, workers: int | None = None) -> Iterator[Any]:
    """A Dask client: of a local cluster of ``workers`` single-threaded processes on
    127.0.0.1 (closed on exit), or of the scheduler at ``scheduler``.

    Raises
    ------
    FleetError
        The scheduler cannot be reached, or the local cluster not started.
    """
    import dask
    from distributed import Client, LocalCluster

    quiet = {
        "distributed.scheduler.allowed-failures": WORKER_DEATHS_FORGIVEN,
        "distributed.admin.tick.limit": "1h",  # long tasks on a busy machine are no news
        "distributed.nanny.pre-spawn-environ": _worker_environ(dask.config),
        # the dashboard's sampling profiler walks the task's stack every 10 ms: CPU a
        # grading needs, for a profile no one looks at
        "distributed.worker.profile.enabled": False,
    }
    with dask.config.set(quiet):
        if scheduler == LOCAL:
            try:
                cluster = LocalCluster(
                    n_workers=local_workers(workers),
                    threads_per_worker=1,
                    processes=True,
                    host="127.0.0.1",
                    dashboard_address="127.0.0.1:0",
                    silence_logs=logging.ERROR,
                )
            except (OSError, RuntimeError, TimeoutError) as exc:
                raise FleetError(f"cannot start a local Dask cluster: {error_text(exc)}") from exc
            try:
                with Client(cluster) as client:
                    yield client
            finally:
                cluster.close()
            return
        if workers is not None:
            raise UsageError(
                "--workers sizes the local cluster; a remote scheduler has its own workers"
            )
        try:
            client = Client(scheduler, timeout=30)
        except (OSError, TimeoutError, ValueError) as exc:
            raise FleetError(
                f"cannot reach the Dask scheduler at {scheduler}: {error_text(exc)}"
            ) from exc
        with client:
            yield client


def _now() -> str:
    return datetime.now(UTC).replace(microsecond=0).isoformat().replace("+00:00", "Z")


@dataclass
class _Run:
    """A run file's tasks while they come back."""

    file: str
    units: list[str] = field(default_factory=list)
    outcomes: dict[str, UnitOutcome] = field(default_factory=dict)

    @property
    def complete(self) -> bool:
        return len(self.outcomes) == len(self.units)

    def graded(self) -> RunGrade | None:
        """The run graded from its units that succeeded (None when none did)."""
        done = [self.outcomes[u] for u in self.units if self.outcomes[u].grade is not None]
        if not done:
            return None
        first = done[0]
        assert first.run is not None and first.profile is not None
        run_units = tuple(o.run.units[0] for o in done if o.run is not None)
        return RunGrade(
            run=replace(first.run, units=run_units),
            profile=first.profile,
            units=tuple(o.grade for o in done if o.grade is not None),
            graded_utc=_now(),
            software_version=software_version(),
        )


class _Driver:
    """Submits the tasks, collects what comes back, stores and writes as runs complete."""

    def __init__(
        self,
        request: FleetRequest,
        client: Any,
        progress: ProgressSink,
        store: StoreQueue | None,
        profile: Profile | None,
        bench: Bench | None,
    ) -> None:
        from distributed import as_completed

        self.request, self.client, self.progress, self.store = request, client, progress, store
        self.profile, self.bench = profile, bench
        self.pending = as_completed()
        self.kind: dict[Any, tuple[str, Any]] = {}
        self.runs: dict[str, _Run] = {}
        self.failed: list[TaskFailure] = []
        self.graded: dict[str, RunGrade] = {}
        self.not_stored: list[NotStored] = []
        self.reports: list[Path] = []
        self.warnings: list[str] = []
        self.tasks = self.done = 0
        self.t0 = time.monotonic()

    def submit(self, what: str, key: Any, fn: Callable[..., Any], *args: Any) -> None:
        future = self.client.submit(fn, *args, pure=False)
        self.kind[future] = (what, key)
        self.pending.add(future)

    def tell(self) -> None:
        self.progress(
            FleetProgress(self.done, self.tasks, time.monotonic() - self.t0, len(self.failed))
        )

    def run(self, files: list[str]) -> None:
        for f in files:
            self.runs[f] = _Run(f)
            self.submit("list", f, list_units, f)
        for future in self.pending:
            what, key = self.kind.pop(future)
            try:
                value = future.result()
                error = ""
            except Exception as exc:  # the task's worker died, or the result did not come back
                value, error = None, lost_task_text(exc)
            getattr(self, f"_on_{what}")(key, value, error)
            if self.store is not None:
                self.store.poll()  # the stores an outage held back, when their back-off is over
            self.tell()
        if self.store is not None:
            self.not_stored = self.store.finish()

    def _on_list(self, file: str, listed: tuple[list[str], str] | None, error: str) -> None:
        units, error = listed if listed is not None else ([], error)
        if error or not units:
            self.tasks += 1
            self.done += 1
            self.failed.append(TaskFailure(file, "", error or "the run has no units"))
            return
        self.runs[file].units = list(units)
        for unit in units:
            self.tasks += 1
            if self.request.action == "analyze":  # the analyze service, with the references
                bench = None if self.request.bench is None else str(self.request.bench)
                self.submit(
                    "unit", (file, unit), analyze_task, file, unit, self.request.profile, bench
                )
            else:
                self.submit("unit", (file, unit), grade_task, file, unit, self.profile,
                            self.bench, self.request.action == "report")

    def _on_unit(self, key: tuple[str, str], outcome: UnitOutcome | None, error: str) -> None:
        file, unit = key
        self.done += 1
        outcome = outcome or UnitOutcome(file, unit, error=error or "no result")
        if outcome.error:
            self.failed.append(TaskFailure(file, unit, outcome.error))
        self.warnings += [w for w in outcome.warnings if w not in self.warnings]
        run = self.runs[file]
        run.outcomes[unit] = outcome
        if run.complete and self.request.action != "analyze":
            self._finish(run)

    def _finish(self, run: _Run) -> None:
        graded = run.graded()
        if graded is None:
            return
        self.graded[run.file] = graded
        if self.request.action == "report":  # stored with its report files when they are back
            self.tasks += 1
            self.submit("report", run.file, report_task, graded, self.request.formats)
        elif self.store is not None:
            self.store.put(run.file, graded)

    def _on_report(self, file: str, files: list[tuple[str, str, bytes]] | None, error: str) -> None:
        self.done += 1
        written: list[tuple[str, Path]] = []
        if error or files is None:
            self.failed.append(TaskFailure(file, "", f"report not written: {error}"))
        else:
            out = self.request.out
            out.mkdir(parents=True, exist_ok=True)
            for fmt, name, data in files:
                path = out / name
                tmp = path.with_name(f".{name}.part")
                tmp.write_bytes(data)
                tmp.replace(path)  # a report is there whole, or not at all
                self.reports.append(path)
                written.append((fmt, path))
        if self.store is not None:
            self.store.put(file, self.graded[file], tuple(written))

    def result(self, files: list[str], workers: int) -> FleetResult:
        order = {f: i for i, f in enumerate(files)}
        failed = sorted(self.failed, key=lambda f: (order.get(f.file, 0), f.unit))
        runs = tuple(self.graded[f] for f in files if f in self.graded)
        analyses = tuple(
            self.runs[f].outcomes[u].analysis
            for f in files
            for u in self.runs[f].units
            if u in self.runs[f].outcomes and self.runs[f].outcomes[u].analysis is not None
        )
        return FleetResult(
            self.request.action,
            self.tasks,
            tuple(failed),
            runs,
            tuple(a for a in analyses if a is not None),
            tuple(self.reports),
            tuple(self.warnings),
            workers,
            time.monotonic() - self.t0,
            sum(len(ids) for ids in self.store.stored.values()) if self.store else 0,
            tuple(self.not_stored),
        )


def fleet(request: FleetRequest, progress: ProgressSink = _ignore) -> FleetResult:
    """Run ``request`` on its cluster: one task per (run file, unit), stored and reported
    by this process as runs complete.

    Raises
    ------
    UsageError
        A source that does not exist, no run files, a bad ``workers`` or format.
    ProfileError, BenchError
        The profile or bench given cannot be loaded (before anything runs).
    FleetError
        The cluster cannot be started or reached.
    ResultsDatabaseError
        The results database cannot be opened (a grading it does not take later, within
        ``db_retry_s``, is listed in ``not_stored`` and the fleet goes on).
    """
    if request.action not in ACTIONS:
        raise UsageError(
            f"unknown fleet action {request.action!r}; use one of {', '.join(ACTIONS)}"
        )
    unknown = [f for f in request.formats if f not in FORMATS]
    if unknown:
        raise UsageError(f"unknown report format {unknown[0]!r}; use one of {', '.join(FORMATS)}")
    files = run_files(request.sources)
    profile = load_profile(request.profile) if request.profile else None  # bad input: before
    bench = load_bench(request.bench) if request.bench is not None else None  # any cluster
    store = request.store and request.action != "analyze"
    with (
        _store_queue(request if store else None) as queue,
        cluster_client(request.scheduler, request.workers) as client,
    ):
        workers = len(client.scheduler_info().get("workers", {}))
        driver = _Driver(request, client, progress, queue, profile, bench)
        driver.run(files)
        return driver.result(files, workers)


@contextmanager
def _store_queue(request: FleetRequest | None) -> Iterator[StoreQueue | None]:
    """The request's results database, opened before any cluster starts (a wrong ``--db``
    fails at once); None when nothing is stored."""
    if request is None:
        yield None
        return
    with StoreQueue(request.database, retry_s=request.db_retry_s) as queue:
        queue.open()
        yield queue
