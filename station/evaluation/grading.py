"""End-of-line grading: every figure of a profile with its confidence interval, and the grade.

For each unit and axis of a run, :func:`grade_run` discards the profile's warm-up, runs the
Allan analysis (:func:`station.evaluation.analyze.analyze_record`) and computes every figure the
profile names with a two-sided interval at the profile's confidence level:

``bias``
    ``|mean|``; interval from 10 batch means (Student t, 9 dof), folded to the magnitude.
``bias_stability_<T>s``
    std of T-second averages; chi-square interval with ``n_averages - 1`` dof.
``arw``, ``bias_instability``, ``adev_min``
    read-offs of the Allan deviation (IEEE 952 Annex C, :mod:`analysis.figures.readoffs`);
    chi-square interval with the edf of the Allan values they are read from. With the
    profile's ``[grading] figure_source = "fit"``, ``arw`` and ``bias_instability`` are the
    fitted N and B instead (``adev_min`` is always read off).
``quantization``, ``arw_fit``, ``bias_instability_fit``, ``rrw``, ``rate_ramp``
    the fitted Q, N, B, K, R; interval ``value +- z stderr`` (normal quantile), clipped at 0.

Each limit is an upper limit and is decided by the profile's rule (see :func:`decide`).
An axis gets the best grade whose every limit it passes; the unit gets its worst axis.
An axis whose read-off and fit of a graded figure disagree by more than their combined
intervals keeps its grade and is flagged for review with the reason
(:func:`axis_review`): neither figure is silently believed.
Grading reads only a :class:`~station.model.runs.RunInfo`, so a stored run is re-graded with any
profile without the device.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from analysis.allan import blocks
from analysis.figures.readoffs import arw_readoff, bias_instability_readoff
from analysis.figures.spec import review_notes
from analysis.units.conversions import DEG_FAMILY, UnitFamily
from devices.resolution import description_resolution
from station.errors import RecordFormatError
from station.evaluation.accel_grading import (
    accel_columns,
    accel_figure_interval,
    accel_only_notes,
    figures_for,
)
from station.evaluation.analyze import AxisAnalysis, analyze_record
from station.evaluation.coverage import RecordCoverage, record_coverage
from station.evaluation.decision import (
    GradingError,
    assign_grade,
    decide,
    grade_rank,
    match_axes,
)
from station.evaluation.figure_intervals import Interval, figure_interval, normal_quantile
from station.evaluation.long_records import return_freed_heap, take_columns
from station.evaluation.readings import (
    Reading,
    alternative_readings,
    best_supported,
    covering_interval,
    fit_term,
    readings_note,
    safe_verdict,
)
from station.evaluation.resolution import (
    AxisResolution,
    axis_resolution,
    below_floor,
    check_not_constant,
)
from station.model.bench import Bench, bench_from_json
from station.model.kinds import INDETERMINATE, Verdict
from station.model.profiles import FigureSpec, Profile
from station.model.records import RateRecord
from station.model.runs import RunInfo, UnitRun
from station.model.sheet_header import SheetHeader
from station.model.version import software_version
from station.storage.scratch import scratch_array

if TYPE_CHECKING:
    from station.evaluation.sequence_grading import UnitSequence

#: Fewest samples left after the warm-up for grading to proceed.
MIN_SAMPLES = 1000


@dataclass(frozen=True)
class FigureResult:
    """One graded figure of one axis, in the profile's unit for that figure.

    ``verdicts`` maps each grade that limits this figure to its verdict; ``alternatives``
    are the other readings an ambiguous fit allows (canonical unit), which the verdicts hold
    for too and ``ci_low``/``ci_high`` cover (:mod:`station.evaluation.readings`); ``terms``
    those of the printed reading the value comes from ("" for a figure that is no fitted
    term).
    """

    spec: FigureSpec
    value: float | None
    ci_low: float | None
    ci_high: float | None
    verdicts: dict[str, Verdict]
    note: str = ""
    alternatives: tuple[Reading, ...] = ()
    terms: str = ""
    #: False where the figure lies below what the link's LSB resolves (its passing
    #: verdicts are then indeterminate: :mod:`station.evaluation.resolution`).
    resolved: bool = True
    #: Its quantization floor in ``spec.unit`` (None: not checked).
    floor: float | None = None

    @property
    def name(self) -> str:
        """The figure's profile key."""
        return self.spec.name

    def as_json(self, grade: str | None) -> dict[str, object]:
        """JSON object of the figure; ``limit``/``verdict`` are those of ``grade``.

        A grade that places no limit on the figure gives ``limit: null, verdict: "pass"``.
        """
        limit = self.spec.limits.get(grade) if grade else None
        verdict = self.verdicts.get(grade, "pass") if grade else None
        return {
            "label": self.spec.label,
            "unit": self.spec.unit,
            "value": self.value,
            "ci_low": self.ci_low,
            "ci_high": self.ci_high,
            "limit": limit,
            "verdict": verdict,
            "limits": dict(self.spec.limits),
            "verdicts": dict(self.verdicts),
            "note": self.note,
            "alternatives": [r.as_json(self.spec.unit_factor) for r in self.alternatives],
            "terms": self.terms,
            "resolved": self.resolved,
            "quantization_floor": self.floor,
        }


@dataclass(frozen=True)
class AxisGrade:
    """The grade of one axis: its figures, its analysis, and which grade decided it.

    ``deciding_grade`` is the grade whose limits the reported ``limit``/``verdict`` are:
    the grade assigned, the first indeterminate grade when the axis is indeterminate, or
    the loosest grade when it is rejected. ``could_reach`` names a better grade the axis
    was indeterminate at (a re-test might reach it).
    """

    axis: str
    grade: str
    deciding_grade: str
    figures: tuple[FigureResult, ...]
    analysis: AxisAnalysis
    could_reach: str | None = None
    review: tuple[str, ...] = ()
    #: The record's step, value census and stuck-output review (None: an accelerometer).
    resolution: AxisResolution | None = None

    @property
    def graded_figures(self) -> tuple[FigureResult, ...]:
        """Figures with at least one limit."""
        return tuple(f for f in self.figures if f.spec.graded)

    def as_json(self) -> dict[str, object]:
        """JSON object of the axis (the ``station grade --json`` interface)."""
        accel = self.analysis.accel
        return {
            "quantity": self.analysis.quantity,
            "grade": self.grade,
            "deciding_grade": self.deciding_grade,
            "could_reach": self.could_reach,
            "review": list(self.review),
            "tones": [t.as_dict() for t in self.analysis.tones],
            "excluded_taus": [z.as_dict() for z in self.analysis.zones],
            "sample_rate_hz": self.analysis.sample_rate_hz,
            "n_samples": self.analysis.n_samples,
            "duration_s": self.analysis.n_samples / self.analysis.sample_rate_hz,
            "figures": {f.name: f.as_json(self.deciding_grade) for f in self.graded_figures},
            "info": {f.name: f.as_json(None) for f in self.figures if not f.spec.graded},
            **({"earth_rate_removed_deg_h": self.analysis.figures.earth_rate_removed_deg_h}
               if accel is None else {"gravity_removed_m_s2": accel.gravity_removed_m_s2}),
            "gaps": self.analysis.gaps.as_json(),
            **({"resolution": self.resolution.as_json()} if self.resolution is not None
               else {}),
            "outliers": self.analysis.outliers.as_json(),
            # the GMWM beside the Allan figures, where the run was analysed with it
            **({"gmwm": self.analysis.gmwm.as_json()} if self.analysis.gmwm is not None
               else {}),
        }


@dataclass(frozen=True)
class UnitGrade:
    """The grade of one unit (its worst axis) and everything it was decided from."""

    unit: UnitRun
    grade: str
    axes: tuple[AxisGrade, ...]
    warmup_discarded_s: float
    notes: tuple[str, ...] = ()
    #: The unit's test-sequence figures, when the run is a sequence
    #: (:mod:`station.evaluation.sequence_grading`); ``grade`` is then the worse of the
    #: axes' grade and the sequence's.
    sequence: UnitSequence | None = None
    #: Missing time and a short record against the profile's test
    #: (:mod:`station.evaluation.coverage`; None: not assessed).
    coverage: RecordCoverage | None = None

    @property
    def review(self) -> tuple[str, ...]:
        """Why the unit needs a person's review (``"axis: reason"`` each, ``"record:
        reason"`` for its coverage); empty when it does not."""
        own = () if self.coverage is None else self.coverage.review
        return (*(f"record: {note}" for note in own),
                *(f"{a.axis}: {note}" for a in self.axes for note in a.review))

    def axis(self, name: str) -> AxisGrade:
        """The axis named ``name``."""
        for a in self.axes:
            if a.axis == name:
                return a
        raise KeyError(f"unit {self.unit.unit_id} has no axis {name!r}")

    def as_json(self) -> dict[str, object]:
        """JSON object of the unit."""
        u = self.unit
        out: dict[str, object] = {
            "unit_id": u.unit_id,
            "model": u.model,
            "serial_number": u.serial_number,
            "grade": self.grade,
            "review": list(self.review),
            "warmup_discarded_s": self.warmup_discarded_s,
            "notes": list(self.notes),
            "axes": {a.axis: a.as_json() for a in self.axes},
        }
        if self.coverage is not None:
            out["coverage"] = self.coverage.as_json()
        if self.sequence is not None:
            out["sequence_figures"] = self.sequence.as_json()
            out["sequence_plateaus"] = [p.as_json() for p in self.sequence.plateaus]
        return out


@dataclass(frozen=True)
class RunGrade:
    """A run graded with a profile."""

    run: RunInfo
    profile: Profile
    units: tuple[UnitGrade, ...]
    graded_utc: str
    software_version: str
    extra: dict[str, str] = field(default_factory=dict)
    #: The bench whose Earth rate the biases are reported without (None: none known).
    bench: Bench | None = None
    #: The test house's part of the spec sheet's header (company, station, approval...).
    sheet: SheetHeader | None = None
    #: The unit family its spec sheets print the figures in (``--output-units``).
    output_units: UnitFamily = DEG_FAMILY

    def as_json(self) -> dict[str, object]:
        """The ``station grade --json`` document (see docs/report-json-schema.md)."""
        p, r, m = self.profile, self.run, self.run.metadata
        doc: dict[str, object] = {
            "schema": "gyro-station/grade",
            "schema_version": 1,
            "graded_utc": self.graded_utc,
            "software_version": self.software_version,
            "profile": {"name": p.name, "version": p.version, "model": p.model, "path": p.path,
                        "sha256": p.sha256, "rule": p.rule, "confidence": p.confidence,
                        "figure_source": p.figure_source,
                        "grades": list(p.grades), "reject": p.reject},
            "run": {"path": r.path, "start_utc": r.start_utc, "stop_utc": r.stop_utc,
                    "operator": m.operator, "lot": m.lot, "station": m.station_host,
                    "software_version": m.software_version, "profile": m.profile,
                    "interrupted": r.interrupted},
            "units": [u.as_json() for u in self.units],
        }
        if "sequence" in self.extra:  # a test sequence: its name, file, segment graded
            doc["sequence"] = {k.removeprefix("sequence_") if k != "sequence" else "name": v
                               for k, v in self.extra.items() if k.startswith("sequence")}
        return doc


# --- figures -------------------------------------------------------------------------------


def grade_figure(spec: FigureSpec, interval: Interval, profile: Profile,
                 alternatives: tuple[Reading, ...] = (), terms: str = "") -> FigureResult:
    """Convert a canonical interval to the spec's unit and decide it at every limited grade,
    safely over the ``alternatives`` (other readings, canonical unit) when there are any.

    ``interval`` is the figure of the reading the sheet prints
    (:func:`station.evaluation.readings.best_supported`), ``terms`` its terms (kept for a
    fitted figure only). Where the record allows other readings, the value stays the
    printed reading's and the interval is widened to cover every other reading
    (:func:`station.evaluation.readings.covering_interval`); each reading is decided on
    its own interval and the verdict holds for all of them
    (:func:`station.evaluation.readings.safe_verdict`)."""
    factor = spec.unit_factor

    def conv(v: float | None) -> float | None:
        return None if v is None or not math.isfinite(v) else v / factor

    term = fit_term(spec.name, profile.figure_source) or ""
    printed = Reading(terms if term else "", interval.value, interval.low, interval.high)
    readings = [(conv(r.value), conv(r.low), conv(r.high)) for r in (printed, *alternatives)]
    verdicts = {g: safe_verdict([decide(*r, limit, profile.rule) for r in readings])
                for g, limit in spec.limits.items()}
    low, high = covering_interval(printed, alternatives)
    widened = (low, high) != (printed.low, printed.high)
    own = "; ".join(t for t in (interval.note, "interval covers every reading the record "
                                "allows" if widened else "") if t)
    note = "; ".join(t for t in (own, readings_note(alternatives, spec.unit, factor)) if t)
    return FigureResult(spec, conv(interval.value), conv(low), conv(high), verdicts, note,
                        alternatives, printed.terms)


# --- runs ----------------------------------------------------------------------------------


def axis_review(analysis: AxisAnalysis, profile: Profile) -> tuple[str, ...]:
    """Why an axis needs review: read-off and fit of a graded figure disagree (at the profile's
    level).

    Only the pairs the profile limits are compared (``arw`` or ``arw_fit``,
    ``bias_instability`` or ``bias_instability_fit``): a disagreement on an informational
    figure cannot change a verdict, and ``station analyze`` reports it anyway.
    """
    graded = {f.name for f in profile.figures if f.graded}
    which = tuple(k for k in ("arw", "bias_instability") if {k, f"{k}_fit"} & graded)
    if not which:
        return ()
    arw = arw_readoff(analysis.allan, analysis.fit, zones=analysis.zones)
    bi = bias_instability_readoff(analysis.allan, zones=analysis.zones)
    return review_notes(
        analysis.allan, analysis.fit, arw, bi, confidence=profile.confidence, which=which
    )



def _scratch_index(n: int) -> np.ndarray:
    """A scratch memmap for the sample index of a long record's part (bounded memory)."""
    return scratch_array((n,), np.int64)


def grade_unit(unit: UnitRun, profile: Profile, bench: Bench | None = None, *,
               recorded_span_s: float | None = None,
               test_duration_s: float | None = None) -> UnitGrade:
    """Grade one unit of a run with ``profile`` (warm-up discarded, every axis the profile names).

    ``bench`` gives the latitude and axis directions whose Earth rate the bias is reported
    without (:mod:`station.model.bench`); ``recorded_span_s`` the recorder's span of the
    run, s (:attr:`RunInfo.recorded_span_s`; None: the record's own); ``test_duration_s``
    the test its coverage is held against (None: the profile's, :mod:`.coverage`).

    Raises
    ------
    GradingError
        When the record is too short after the warm-up or lacks a profile axis;
        :class:`~station.evaluation.resolution.ConstantRecordError` when an axis holds one
        value throughout.
    """
    record = unit.record
    fs = record.sample_rate_hz
    try:
        kept = (record.slice_time(profile.warmup_s, index_out=_scratch_index)
                if profile.warmup_s > 0 else record)
    except RecordFormatError:
        kept = None
    if kept is None or kept.n_samples < MIN_SAMPLES:
        raise GradingError(
            f"unit {unit.unit_id}: {record.n_samples} samples ({record.duration_s:.0f} s) "
            f"leave fewer than {MIN_SAMPLES} after the {profile.warmup_s:g} s warm-up"
        )
    columns = match_axes(profile.axes, record.axis_names) if record.axis_names else {}
    accel = accel_columns(profile, kept)
    notes = accel_only_notes(profile, record, accel)
    trimmed = RateRecord(
        take_columns(kept.rate_deg_s, list(columns.values())),
        fs,
        tuple(columns),
        record.source,
        kept.temperature_c,
        kept.sample_index,
        None if not accel or kept.accel_m_s2 is None
        else take_columns(kept.accel_m_s2, list(accel.values())),
        tuple(kept.accel_axis_names[i] for i in accel.values()),
    )
    for i, name in enumerate(trimmed.axis_names):
        check_not_constant(trimmed.rate_deg_s[:, i], f"unit {unit.unit_id} axis {name}")
    if unit.model and unit.model != profile.model:
        notes.append(f"unit model {unit.model!r} differs from the profile's {profile.model!r}")
    if trimmed.missing_samples:
        notes.append(
            f"{trimmed.missing_samples} samples missing in gaps after the warm-up: no Allan "
            "difference or average straddles a gap"
        )
    if profile.sample_rate_hz and abs(fs - profile.sample_rate_hz) > 1e-6 * fs:
        notes.append(f"sample rate {fs:g} Hz, profile says {profile.sample_rate_hz:g} Hz")
    link = description_resolution(unit.lsb_deg_s, unit.lsb_relative)
    axes = []
    for analysed in analyze_record(trimmed, method=profile.fit_method, bench=bench):
        # the sheet's figures are those of one reading, the one the record supports best
        analysis = (analysed if analysed.accel is not None
                    else replace(analysed, fit=best_supported(analysed.fit)))
        x = analysis.rate_deg_s
        assert x is not None
        z, source = normal_quantile(profile.confidence), profile.figure_source
        is_accel = analysis.accel is not None
        interval_of = accel_figure_interval if is_accel else figure_interval
        figures = tuple(
            grade_figure(
                spec,
                interval_of(spec.name, x, analysis, profile.confidence, source=source),
                profile,
                () if is_accel or (term := fit_term(spec.name, source)) is None
                else alternative_readings(analysis.fit, term, z),
                "" if is_accel else analysis.fit.terms,
            )
            for spec in figures_for(profile, analysis)
        )
        resolution = None
        if not is_accel:
            resolution = axis_resolution(
                trimmed.rate_deg_s[:, trimmed.axis_names.index(analysis.name)], fs, link)
            figures = _floored(figures, resolution, analysis, profile)
            if blocks.is_long(len(x)):
                return_freed_heap()
        grade, deciding, could = assign_grade(figures, profile.grades, profile.reject)
        review = () if is_accel else axis_review(analysis, profile)
        axes.append(AxisGrade(analysis.name, grade, deciding, figures, analysis, could,
                              review + (resolution.stuck if resolution else ()), resolution))
    coverage = record_coverage(record, profile, recorded_span_s, test_duration_s)
    if coverage.insufficient:  # no passing grade on too little of the test
        axes = [replace(a, grade=INDETERMINATE, could_reach=a.grade)
                if a.grade in profile.grades else a for a in axes]
    worst = max(axes, key=lambda a: grade_rank(a.grade, profile)).grade
    return UnitGrade(unit, worst, tuple(axes), profile.warmup_s if profile.warmup_s > 0 else 0.0,
                     tuple(notes), coverage=coverage)


def _floored(figures: tuple[FigureResult, ...], resolution: AxisResolution,
             analysis: AxisAnalysis, profile: Profile) -> tuple[FigureResult, ...]:
    """``figures`` with those below their quantization floor made indeterminate."""
    tau = bias_instability_readoff(analysis.allan, zones=analysis.zones).tau_low_s
    record_s = analysis.n_samples / analysis.sample_rate_hz
    out = []
    for f in figures:
        below = below_floor(f.name, f.spec.unit, f.spec.unit_factor, f.value, f.ci_low,
                            f.ci_high, resolution, tau_s=tau, record_s=record_s,
                            confidence=profile.confidence)
        if below is not None:
            verdicts = {g: INDETERMINATE if v == "pass" else v for g, v in f.verdicts.items()}
            f = replace(f, verdicts=verdicts, note="; ".join(t for t in (below.why, f.note) if t),
                        resolved=False, floor=below.floor)
        out.append(f)
    return tuple(out)


def grade_run(run: RunInfo, profile: Profile, *, units: tuple[str, ...] = (),
              bench: Bench | None = None, own_span: bool = False) -> RunGrade:
    """Grade every unit of ``run`` (or those named in ``units``) with ``profile``.

    ``own_span``: hold each record's coverage against its own span instead of the
    profile's test (a test sequence's noise segment, shorter by design): only its
    missing time counts.

    ``bench`` defaults to the one the run file recorded (none for a CSV record). Works
    on any stored run: nothing here talks to a device.
    """
    chosen = [run.unit(u) for u in units] if units else list(run.units)
    bench = bench if bench is not None else bench_from_json(run.metadata.bench)
    graded = tuple(grade_unit(u, profile, bench, recorded_span_s=run.recorded_span_s,
                              test_duration_s=u.record.duration_s if own_span else None)
                   for u in chosen)
    now = datetime.now(UTC).replace(microsecond=0).isoformat().replace("+00:00", "Z")
    return RunGrade(run, profile, graded, now, software_version(), bench=bench)


def run_profile_ref(run: RunInfo) -> str:
    """How to load the profile ``run`` was recorded with: the file it was read from if it
    is still there (a line's own profile folder), else its name (``profiles/NAME.toml``);
    "" when the run names none."""
    recorded = run.metadata
    if recorded.profile_path and Path(recorded.profile_path).is_file():
        return recorded.profile_path
    return recorded.profile


def profile_changed_note(run: RunInfo, profile: Profile) -> str | None:
    """Why ``profile`` is not the file ``run`` was recorded with, or None if it is (or the
    run did not record one: a CSV record, a run without a profile).

    The run file keeps the profile's version and SHA-256; a profile edited since (new
    limits, a new grade) grades the old run by today's rules, which a re-grade may
    intend but should say.
    """
    recorded = run.metadata
    if not recorded.profile_sha256 or recorded.profile_sha256 == profile.sha256:
        return None
    return (f"profile {profile.name} changed since {run.path} was recorded with it "
            f"(recorded: version {recorded.profile_version or '?'}, sha256 "
            f"{recorded.profile_sha256[:12]}; now: version {profile.version}, sha256 "
            f"{profile.sha256[:12]} in {profile.path}): grading with the current file")


def regrade(previous: RunGrade, profile: Profile) -> RunGrade:
    """The same run graded with another profile (the run's records, no device)."""
    return replace(grade_run(previous.run, profile, bench=previous.bench),
                   extra={"regraded_from": previous.profile.ref})
