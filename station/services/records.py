"""Reading the part of a record a workflow analyses: file, unit, axis, time slice, warm-up."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from station.errors import ProfileError, RecordFormatError, UsageError
from station.evaluation.settings import settings_of
from station.model.bench import Bench, bench_from_json, load_bench
from station.model.profiles import load_profile
from station.model.records import RateRecord
from station.storage.runs import read_record, recorded_attributes


@dataclass(frozen=True)
class RecordSource:
    """Which record, and which part of it (times in s from the record start).

    Attributes
    ----------
    file : str or Path
        A CSV record (plain or ``.csv.gz``) or a run file (``.h5``).
    rate_hz : float or None
        Sample rate of a CSV record without a time column, Hz.
    units : str
        Unit of a CSV record's rate columns (``deg/s``, ``rad/s``, ``deg/h``).
    accel_units : str
        Unit of a CSV record's accelerometer columns (``m/s^2``, ``g``, ``mg``).
    axis, unit : str or None
        Only this axis (column name); run files: this unit (id or serial; default the first).
    start_s, stop_s : float, float or None
        The time slice to analyse (``stop_s`` None: to the end).
    profile : str or None
        Product profile whose warm-up is discarded (run files: default the run's).
    warmup_s : float or None
        Warm-up to discard, s (overrides the profile's).
    """

    file: str | Path
    rate_hz: float | None = None
    units: str = "deg/s"
    axis: str | None = None
    accel_units: str = "m/s^2"
    unit: str | None = None
    start_s: float = 0.0
    stop_s: float | None = None
    profile: str | None = None
    warmup_s: float | None = None


@dataclass(frozen=True)
class RecordSelection:
    """Which part of a record was analyzed (times in s from the record start)."""

    unit: str | None
    axis: str | None
    start_s: float
    stop_s: float | None
    warmup_s: float
    warmup_from: str


@dataclass(frozen=True)
class LoadedRecord:
    """The selected record, what was selected, and notes for the operator."""

    record: RateRecord
    selection: RecordSelection
    notes: tuple[str, ...] = ()


def _warmup(source: RecordSource) -> tuple[float, str, tuple[str, ...]]:
    """(warm-up to discard in s, where that figure comes from, notes)."""
    if source.warmup_s is not None:
        return source.warmup_s, "--warmup-s", ()
    ref = source.profile
    if ref is None:
        ref = recorded_attributes(source.file).get("profile") or None
        if ref is not None:
            try:
                warmup = settings_of(load_profile(ref)).warmup_s
            except ProfileError as exc:
                return 0.0, "none", (f"the run's profile {ref!r} cannot be loaded ({exc}); no "
                                     f"warm-up discarded",)
            return warmup, f"profile {ref} (recorded in the run)", ()
    if ref is None:
        return 0.0, "none", ()
    return settings_of(load_profile(ref)).warmup_s, f"profile {ref}", ()


def load_record(source: RecordSource) -> LoadedRecord:
    """The record ``source`` selects: file, unit, axis, time slice, warm-up cut.

    The analyzed span starts at ``max(start_s, warm-up)`` and ends at ``stop_s``.

    Raises
    ------
    UsageError
        A negative or empty time slice.
    """
    record = read_record(source.file, sample_rate_hz=source.rate_hz, units=source.units,
                         unit=source.unit, accel_units=source.accel_units)
    if source.axis is not None:
        record = record.select(source.axis)
    return cut_record(record, source)


def cut_record(record: RateRecord, source: RecordSource) -> LoadedRecord:
    """``record`` (read from ``source.file``) without its warm-up and outside the time slice
    ``source`` names; the one place the warm-up and the slice are applied.

    Raises
    ------
    UsageError
        A negative or empty time slice.
    RecordFormatError
        A record of fewer than 2 samples (an empty run: its recorder stopped before the
        first flush, or a salvage that kept nothing of this unit).
    """
    if record.n_samples < 2:
        raise RecordFormatError(f"{record.source}: {record.n_samples} samples recorded, "
                                f"nothing to analyze (an empty run)")
    warmup_s, where, notes = _warmup(source)
    start, stop = source.start_s, source.stop_s
    if start < 0 or warmup_s < 0 or (stop is not None and stop <= max(start, warmup_s)):
        raise UsageError(f"time slice {start}..{stop} s with {warmup_s} s of warm-up is empty "
                         f"or negative")
    start_s = max(start, warmup_s)
    if start_s > 0 or stop is not None:
        record = record.slice_time(start_s, stop)
    selection = RecordSelection(source.unit, source.axis, start_s, stop, warmup_s, where)
    return LoadedRecord(record, selection, notes)


def bench_of(bench_file: str | Path | None, run_file: str | Path | None = None) -> Bench | None:
    """The bench of ``bench_file``, else the one ``run_file`` recorded, else None."""
    if bench_file is not None:
        return load_bench(bench_file)
    recorded = recorded_attributes(run_file).get("bench", "") if run_file is not None else ""
    return bench_from_json(recorded)
