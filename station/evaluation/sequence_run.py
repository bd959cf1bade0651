"""Grading a sequence file: the noise figures of one segment, and the sequence's figures.

A sequence's units are graded on two things: the profile's usual figures (ARW, bias
instability, ...), from the longest segment that ran to its end (the noise of a unit at
its steadiest: a turn-on record after its warm-up, a temperature plateau), and the
sequence figures (:mod:`station.evaluation.sequence_grading`) from every segment. A unit
gets the worse of the two grades. A segment too short for the noise figures leaves the
unit graded on the sequence figures alone, with a note.
"""

from __future__ import annotations

from dataclasses import replace
from datetime import UTC, datetime

from station.errors import RecordFormatError
from station.evaluation.decision import GradingError, grade_rank
from station.evaluation.grading import RunGrade, UnitGrade, grade_run
from station.evaluation.sequence_grading import grade_unit_sequence
from station.model.bench import Bench, bench_from_json
from station.model.kinds import INDETERMINATE
from station.model.profiles import Profile
from station.model.runs import RunInfo, UnitRun
from station.model.sequence_runs import Segment, SequenceRun
from station.model.version import software_version
from station.storage.runs import open_run
from station.storage.sequence_files import segment_path


def noise_segment(run: SequenceRun) -> tuple[Segment, RunInfo] | None:
    """The longest segment that ran to its end (the latest of equals; none a redone step
    superseded), read; None when no segment reads."""
    best: tuple[float, int, Segment, RunInfo] | None = None
    for n, seg in enumerate(run.segments):
        if seg.superseded:
            continue
        try:
            info = open_run(segment_path(run, seg))
        except (OSError, RecordFormatError):
            continue
        if not info.units:
            continue
        length = min(u.record.duration_s for u in info.units)
        key = (0.0 if seg.interrupted else length, n)
        if best is None or key > best[:2]:
            best = (*key, seg, info)
    return None if best is None else (best[2], best[3])


def _worse(a: str, b: str, profile: Profile) -> str:
    if not b:
        return a
    return a if grade_rank(a, profile) >= grade_rank(b, profile) else b


def grade_sequence(run: SequenceRun, profile: Profile, *, units: tuple[str, ...] = (),
                   bench: Bench | None = None) -> RunGrade:
    """Grade every unit of a sequence (or those named) with ``profile``.

    Raises
    ------
    ProfileError
        The profile has no sequence of the run's name.
    GradingError
        No segment can be read, or a unit named that the sequence does not have.
    """
    spec = profile.sequence(run.name)
    chosen = units or run.unit_ids
    unknown = [u for u in chosen if u not in run.unit_ids]
    if unknown:
        raise GradingError(f"{run.path}: no unit {', '.join(unknown)}; units: "
                           f"{', '.join(run.unit_ids)}")
    picked = noise_segment(run)
    if picked is None:
        raise GradingError(f"{run.path}: no segment can be read (the sequence recorded "
                           f"nothing yet, or its segment files are missing)")
    segment, info = picked
    bench = bench if bench is not None else bench_from_json(info.metadata.bench)
    meta = replace(info.metadata, operator=run.operator or info.metadata.operator,
                   lot=run.lot or info.metadata.lot)
    info = replace(info, path=run.path, metadata=meta, interrupted=not run.done)
    grades: list[UnitGrade] = []
    for unit_id in chosen:
        sequence = grade_unit_sequence(run, unit_id, profile, spec)
        unit = next((u for u in info.units if u.unit_id == unit_id), None)
        try:
            if unit is None:
                raise GradingError(f"{unit_id} is not in {segment.file}")
            base = grade_run(replace(info, units=(unit,)), profile, bench=bench,
                             own_span=True).units[0]
            notes = (*base.notes, f"noise figures from segment {segment.file} (step "
                                  f"{segment.step + 1}, cycle {segment.cycle})")
        except GradingError as exc:
            base = UnitGrade(unit or UnitRun(unit_id, "", "", info.units[0].record), "", (),
                             0.0)
            notes = (f"noise figures not graded: {exc}",)
        grade = _worse(base.grade, sequence.grade, profile) if base.grade else (
            sequence.grade or INDETERMINATE)
        grades.append(replace(base, grade=grade, notes=(*notes, *sequence.notes),
                              sequence=sequence))
    now = datetime.now(UTC).replace(microsecond=0).isoformat().replace("+00:00", "Z")
    extra = {"sequence": run.name, "sequence_file": run.path, "sequence_state": run.state,
             "sequence_noise_segment": segment.file,
             "sequence_interruptions": str(len(run.interruptions()))}
    return RunGrade(info, profile, tuple(grades), now, software_version(), extra=extra,
                    bench=bench)
