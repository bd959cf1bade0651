"""What a fleet worker runs: one task per (run file, unit), and one report task per run.

Tasks take file paths, never open files or h5py objects: each opens its run file
read-only itself (:func:`station.storage.hdf5.read_run` of the one unit), and returns a small
result: the unit's grade without its samples (:func:`strip_unit`), the run's metadata
without records, or a report's bytes. A task never raises for a bad input: a corrupt
file, a bad profile or a run too short comes back as :attr:`UnitOutcome.error` (one line,
as the CLI prints it), so the driver reports it and the other tasks go on.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from analysis.errors import AnalysisError
from devices.errors import DeviceError
from station.errors import StationError
from station.evaluation.gmwm_run import run_with_profile_gmwm
from station.evaluation.grading import (
    RunGrade,
    UnitGrade,
    grade_run,
    profile_changed_note,
    run_profile_ref,
)
from station.model.bench import Bench
from station.model.profiles import Profile, load_profile
from station.model.records import RateRecord
from station.model.runs import RunInfo, UnitRun
from station.storage.runs import is_run_file, open_run


def error_text(exc: BaseException) -> str:
    """One line saying what went wrong: the message of the station's own errors (as the CLI
    prints them), the exception's type and message otherwise."""
    if isinstance(exc, FileNotFoundError) and exc.filename:
        return f"no such file: {exc.filename}"
    message = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    if isinstance(exc, StationError | AnalysisError | DeviceError):
        return message or type(exc).__name__
    return f"{type(exc).__name__}: {message}" if message else type(exc).__name__


def _empty(record: RateRecord) -> RateRecord:
    """The record's description (rate, axes, accelerometer axes, source) without its
    samples."""
    accel = (None if record.accel_m_s2 is None
             else np.empty((0, len(record.accel_axis_names))))
    return RateRecord(
        np.empty((0, len(record.axis_names))),
        record.sample_rate_hz,
        record.axis_names,
        record.source,
        accel_m_s2=accel,
        accel_axis_names=record.accel_axis_names,
    )


def strip_run(run: RunInfo) -> RunInfo:
    """The run's metadata and units with every record emptied (what travels back)."""
    return replace(run, units=tuple(replace(u, record=_empty(u.record)) for u in run.units))


def strip_unit(graded: UnitGrade) -> UnitGrade:
    """A unit's grade without its samples: the record emptied and each axis' rate dropped;
    its figures, Allan curves and fit are kept (they are what the JSON, the database and
    a report's tables show)."""
    axes = tuple(replace(a, analysis=replace(a.analysis, rate_deg_s=None)) for a in graded.axes)
    return replace(graded, unit=replace(graded.unit, record=_empty(graded.unit.record)), axes=axes)


@dataclass(frozen=True)
class UnitOutcome:
    """What a task sends back for one (run file, unit).

    Attributes
    ----------
    file, unit : str
        The run file as given, and the unit id.
    error : str
        Why the task failed ("" when it did not).
    run : RunInfo or None
        The run's metadata with this unit, records emptied (:func:`strip_run`).
    grade : UnitGrade or None
        ``grade``/``report``: the unit's grade, samples dropped (:func:`strip_unit`).
    profile : Profile or None
        The profile the unit was graded with.
    warnings : tuple of str
        What the operator should know (the run's profile changed since it was recorded).
    analysis : dict or None
        ``analyze``: the ``station analyze --json`` object of the unit.
    """

    file: str
    unit: str
    error: str = ""
    run: RunInfo | None = None
    grade: UnitGrade | None = None
    profile: Profile | None = None
    warnings: tuple[str, ...] = ()
    analysis: dict[str, object] | None = None


def list_units(path: str) -> tuple[list[str], str]:
    """Unit ids of a run file in recording order (a CSV record: its one unit), and "" ; or
    no units and why the file cannot be read (the driver reports it as the file's failure)."""
    if not is_run_file(path):
        return [Path(path).name.split(".")[0]], ""
    from station.storage.hdf5 import open_run_file, unit_ids

    try:
        with open_run_file(path) as f:
            return unit_ids(f), ""
    except Exception as exc:  # a corrupt file goes back as text: the other files go on
        return [], error_text(exc)


def read_unit_run(path: str, unit: str) -> RunInfo:
    """The run with only ``unit`` read (a CSV record: the whole record)."""
    run = open_run(path, only=(unit,))
    if not run.units:
        raise StationError(f"{path}: no unit {unit!r}")
    return run


def _profile_of(run: RunInfo, profile: Profile | None) -> tuple[Profile, tuple[str, ...]]:
    if profile is not None:
        return profile, ()
    ref = run_profile_ref(run)
    if not ref:
        raise StationError(f"{run.path} names no profile; pass --profile NAME")
    loaded = load_profile(ref)
    note = profile_changed_note(run, loaded)
    return loaded, (note,) if note else ()


def grade_task(path: str, unit: str, profile: Profile | None, bench: Bench | None,
               gmwm: bool = False) -> UnitOutcome:
    """Grade one unit of a run file exactly as ``station grade`` grades it (the given
    profile, else the run's; the given bench, else the run's); with ``gmwm``, add the
    GMWM the profile asks for (``[test] gmwm_model``) as ``station report`` does."""
    try:
        run = read_unit_run(path, unit)
        used, warnings = _profile_of(run, profile)
        graded = grade_run(run, used, bench=bench)
        if gmwm:  # on the samples, before they are dropped
            graded = run_with_profile_gmwm(graded)
        return UnitOutcome(
            path,
            unit,
            run=strip_run(run),
            grade=strip_unit(graded.units[0]),
            profile=used,
            warnings=warnings,
        )
    except Exception as exc:  # every failure goes back as text: the other tasks go on
        return UnitOutcome(path, unit, error=error_text(exc))


def analyze_task(path: str, unit: str, profile: str | None, bench: str | None) -> UnitOutcome:
    """Analyse one unit of a run file as ``station analyze FILE --unit U [--profile P]
    [--bench B] --json`` does (the analyze service, on this worker)."""
    from station.services.analyze import AnalyzeRequest, analyze
    from station.services.records import RecordSource

    try:
        result = analyze(
            AnalyzeRequest(RecordSource(path, unit=unit, profile=profile), bench=bench)
        )
        return UnitOutcome(path, unit, warnings=result.notes, analysis=result.as_json())
    except Exception as exc:  # every failure goes back as text: the other tasks go on
        return UnitOutcome(path, unit, error=error_text(exc))


def report_task(graded_run: object, formats: tuple[str, ...]) -> list[tuple[str, str, bytes]]:
    """The report files of a graded run as ``(format, file name, bytes)``; the driver writes
    them. The run file is opened again read-only for the records the spec sheets plot
    (the DAVAR map); the grades are those the unit tasks sent.

    Raises
    ------
    StationError, OSError
        The run file cannot be read again (the driver reports it for the run).
    """
    from station.output.report import write_report

    assert isinstance(graded_run, RunGrade)
    full = open_run(graded_run.run.path, only=[u.unit.unit_id for u in graded_run.units])
    records = {u.unit_id: u for u in full.units}
    units = tuple(
        replace(u, unit=_with_record(u.unit, records[u.unit.unit_id])) for u in graded_run.units
    )
    graded = replace(graded_run, units=units)
    out = []
    with tempfile.TemporaryDirectory(prefix="station-fleet-") as tmp:
        for fmt in formats:
            path = write_report(graded, fmt, tmp)
            out.append((fmt, path.name, path.read_bytes()))
    return out


def _with_record(stripped: UnitRun, full: UnitRun) -> UnitRun:
    return replace(stripped, record=full.record)
