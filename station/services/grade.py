"""``grade``: every figure of a profile with its interval and the grade, per unit of a run;
storing the grading in the results database."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

from station.errors import GradingNotStoredError, SerialConflictError, UsageError
from station.evaluation.grading import RunGrade, grade_run, profile_changed_note, run_profile_ref
from station.model.profiles import available_profiles, load_profile
from station.model.runs import RunInfo
from station.output.results import default_database_path
from station.output.results_backends import DatabaseLocation
from station.output.results_queue import STORE_RETRY_S, StoreQueue
from station.output.results_store import ReportFile
from station.services.records import bench_of
from station.storage.runs import open_run
from station.storage.sequence_files import is_sequence_file


class NoProfileError(UsageError):
    """The run names no profile and none was given (or matched its units' model)."""


@dataclass(frozen=True)
class RunSource:
    """A run file, and the metadata to set on it before it is graded.

    Attributes
    ----------
    path : str or Path
        A recorder run file (``.h5``) or a CSV record (a run of one unit).
    rate_hz, units, accel_units
        Sample rate (Hz), rate unit and accelerometer unit of a CSV record (see
        :class:`RecordSource`).
    serial, lot, operator : str or None
        Serial number of a CSV record's unit; lot and operator of the run (override the
        run's). None: as recorded.
    lsb_deg_s : float or None
        The rate word's LSB, deg/s, for every unit (a CSV record's ``--lsb``; overrides a
        run file's). None: as recorded, else read off the values.
    """

    path: str | Path
    rate_hz: float | None = None
    units: str = "deg/s"
    serial: str | None = None
    accel_units: str = "m/s^2"
    lot: str | None = None
    operator: str | None = None
    lsb_deg_s: float | None = None


@dataclass(frozen=True)
class GradeRequest:
    """What to grade, and with which profile.

    Attributes
    ----------
    run : RunSource
        The run.
    profile : str or None
        Profile name or TOML path (None: the run's).
    units : tuple of str
        Grade only these units (ids or serial numbers); empty: every unit.
    bench : str, Path or None
        Bench file (None: the run's).
    profile_from_model : bool
        When the run names no profile and none is given, take the first profile whose
        model is a unit's model (the TUI's spec sheet) instead of refusing.
    db : str, Path or None
        Results database: an SQLite file or a PostgreSQL URL (None: :func:`default_database_path`).
    store : bool
        Whether the grading is stored (:func:`store_grading`).
    db_retry_s : float
        How long a results database that is away is waited for before the grading is
        reported not stored, s.
    """

    run: RunSource
    profile: str | None = None
    units: tuple[str, ...] = ()
    bench: str | Path | None = None
    profile_from_model: bool = False
    db: DatabaseLocation | None = None
    store: bool = True
    db_retry_s: float = STORE_RETRY_S

    @property
    def database(self) -> DatabaseLocation:
        """The results database the request names."""
        return self.db or default_database_path()


@dataclass(frozen=True)
class GradeResult:
    """The graded run, and what the operator should know about how it was graded."""

    graded: RunGrade
    warnings: tuple[str, ...] = ()


def open_run_source(source: RunSource) -> RunInfo:
    """The run ``source`` names, with its serial number, lot and operator applied.

    Raises
    ------
    UsageError
        A serial number for a run of several units.
    """
    run = open_run(source.path, sample_rate_hz=source.rate_hz, units=source.units,
                   accel_units=source.accel_units)
    if source.serial is not None:
        if len(run.units) != 1:
            raise UsageError(f"--serial applies to a run of one unit; {source.path} has "
                             f"{len(run.units)}")
        run = replace(run, units=(replace(run.units[0], serial_number=source.serial),))
    if source.lsb_deg_s is not None:
        if not (math.isfinite(source.lsb_deg_s) and source.lsb_deg_s > 0):
            raise UsageError(f"--lsb must be a finite number > 0 (deg/s), got "
                             f"{source.lsb_deg_s:g}")
        run = replace(run, units=tuple(replace(u, lsb_deg_s=source.lsb_deg_s, lsb_relative=0.0)
                                       for u in run.units))
    changes = {k: v for k, v in (("lot", source.lot), ("operator", source.operator))
               if v is not None}
    return replace(run, metadata=replace(run.metadata, **changes)) if changes else run


def guess_profile(run: RunInfo) -> str | None:
    """The run's profile, else the first profile whose model is a unit's model."""
    if run.metadata.profile:
        return run_profile_ref(run)
    models = {u.model for u in run.units}
    for name in available_profiles():
        try:
            if load_profile(name).model in models:
                return name
        except (OSError, ValueError):
            continue
    return None


def grade(request: GradeRequest) -> GradeResult:
    """Open the run, load the profile (given, or the run's) and grade it; nothing is stored.

    Raises
    ------
    NoProfileError
        The run names no profile and none was given (or matched).
    StationError, AnalysisError
        An unreadable run or profile, a run too short to grade.
    """
    if is_sequence_file(request.run.path):
        return _grade_sequence(request)
    run = open_run_source(request.run)
    ref = request.profile or (guess_profile(run) if request.profile_from_model
                              else run_profile_ref(run))
    if not ref:
        raise NoProfileError(f"{request.run.path} names no profile; pass --profile NAME")
    profile = load_profile(ref)
    warnings: tuple[str, ...] = ()
    if not request.profile:
        note = profile_changed_note(run, profile)
        warnings = (note,) if note else ()
    graded = grade_run(run, profile, units=request.units,
                       bench=bench_of(request.bench) if request.bench is not None else None)
    return GradeResult(graded, warnings)


def _grade_sequence(request: GradeRequest) -> GradeResult:
    """A sequence file: its units' noise figures (one segment) and sequence figures."""
    from pathlib import Path

    from station.evaluation.sequence_run import grade_sequence
    from station.storage.sequence_files import read_sequence

    seq = read_sequence(request.run.path)
    recorded = seq.profile_path if seq.profile_path and Path(seq.profile_path).is_file() \
        else seq.profile
    profile = load_profile(request.profile or recorded)
    warnings = []
    if not request.profile and seq.profile_sha256 and seq.profile_sha256 != profile.sha256:
        warnings.append(f"profile {profile.name} changed since the sequence was run "
                        f"(sha256 {seq.profile_sha256[:12]} then, {profile.sha256[:12]} now): "
                        f"grading with the current file")
    if not seq.done:
        warnings.append(f"{request.run.path}: the sequence is {seq.state} (not every step "
                        f"ran): its figures come from what was recorded")
    graded = grade_sequence(seq, profile, units=request.units,
                            bench=bench_of(request.bench) if request.bench is not None else None)
    return GradeResult(graded, tuple(warnings))


def store_grading(graded: RunGrade, db_path: DatabaseLocation, *,
                  reports: tuple[ReportFile, ...] = (), join: bool = False,
                  retry_s: float = STORE_RETRY_S) -> list[int]:
    """Store the grading of every unit (and the report files written for it) in the results
    database; returns the grading ids. A grading stored before is not stored twice (its ids
    are returned); ``join``: nor is another grading of the same run, unit and profile
    file (a report joins the grading stored before). A database that is away is tried
    again with back-off for ``retry_s`` seconds (:class:`StoreQueue`).

    Raises
    ------
    SerialConflictError
        A unit's serial is another unit's in the database (nothing stored).
    GradingNotStoredError
        The database did not take the grading within ``retry_s`` (it says what to do).
    """
    with StoreQueue(db_path, retry_s=retry_s) as queue:
        queue.put(str(graded.run.path), graded, reports, join=join)
        for lost in queue.finish():
            if lost.conflict:
                raise SerialConflictError(lost.error)
            raise GradingNotStoredError(
                f"{graded.run.path}: grading not stored: the results database did not take "
                f"it within {retry_s:g} s ({lost.error})")
        return queue.stored[str(graded.run.path)]
