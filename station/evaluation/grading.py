"""End-of-line grading: every figure of a profile with its confidence interval, and the grade.

For each unit and axis of a run, :func:`grade_run` discards the profile's warm-up, runs the
Allan analysis (:func:`station.evaluation.analyze.analyze_record`) and computes every figure the
profile names with a two-sided interval at the profile's confidence level:

``bias``
    ``|mean|``; interval from 10 batch means (Student t, 9 dof), folded to the magnitude.
``bias_stability_<T>s``
    std of T-second averages; chi-square interval with ``n_averages - 1`` dof.
``arw``, ``bias_instability``, ``adev_min``
    read-offs of the Allan deviation (IEEE 952 Annex C, :mod:`analysis.readoffs`);
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
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import numpy as np
from scipy import stats

from analysis import blocks
from analysis.confidence import chi2_interval
from analysis.figures import bias_stability, review_notes
from analysis.fit import NoiseCoefficients
from analysis.partial_clusters import white_level
from analysis.readoffs import BIAS_INSTABILITY_FACTOR, arw_readoff, bias_instability_readoff
from analysis.units import DEG_FAMILY, S_PER_H, UnitFamily
from station.errors import RecordFormatError, StationError
from station.evaluation.analyze import AxisAnalysis, analyze_record
from station.evaluation.long_records import take_columns
from station.evaluation.readings import (
    FIT_TERM as _FIT_TERM,
    Reading,
    alternative_readings,
    fit_term,
    readings_note,
    safe_verdict,
)
from station.model.bench import Bench, bench_from_json
from station.model.kinds import INDETERMINATE, Verdict
from station.model.profiles import (
    DEFAULT_FIGURE_SOURCE,
    FigureSpec,
    Profile,
    bias_stability_average_s,
)
from station.model.records import RateRecord
from station.model.runs import RunInfo, UnitRun
from station.model.sheet_header import SheetHeader
from station.model.version import software_version
from station.storage.scratch import scratch_array

if TYPE_CHECKING:
    from station.evaluation.sequence_grading import UnitSequence

#: Batches of the batch-means interval of the bias.
BIAS_BATCHES = 10
#: Fewest samples left after the warm-up for grading to proceed.
MIN_SAMPLES = 1000


class GradingError(StationError, ValueError):
    """A run that cannot be graded with a profile (too short, axes missing, ...)."""


@dataclass(frozen=True)
class Interval:
    """A figure in its canonical unit with its two-sided confidence interval (None if unknown)."""

    value: float | None
    low: float | None
    high: float | None
    note: str = ""


@dataclass(frozen=True)
class FigureResult:
    """One graded figure of one axis, in the profile's unit for that figure.

    ``verdicts`` maps each grade that limits this figure to its verdict; ``alternatives``
    are the other readings an ambiguous fit allows (canonical unit), which the verdicts hold
    for too (:mod:`station.evaluation.readings`).
    """

    spec: FigureSpec
    value: float | None
    ci_low: float | None
    ci_high: float | None
    verdicts: dict[str, Verdict]
    note: str = ""
    alternatives: tuple[Reading, ...] = ()

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

    @property
    def graded_figures(self) -> tuple[FigureResult, ...]:
        """Figures with at least one limit."""
        return tuple(f for f in self.figures if f.spec.graded)

    def as_json(self) -> dict[str, object]:
        """JSON object of the axis (the ``station grade --json`` interface)."""
        return {
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
            "earth_rate_removed_deg_h": self.analysis.figures.earth_rate_removed_deg_h,
            "gaps": self.analysis.gaps.as_json(),
            "outliers": self.analysis.outliers.as_json(),
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

    @property
    def review(self) -> tuple[str, ...]:
        """Why the unit needs a person's review (``"axis: reason"`` each); empty when it does
        not."""
        return tuple(f"{a.axis}: {note}" for a in self.axes for note in a.review)

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


# --- decision ------------------------------------------------------------------------------


def decide(
    value: float | None, low: float | None, high: float | None, limit: float, rule: str
) -> Verdict:
    """Verdict of one figure against an upper ``limit`` under a decision rule.

    ``simple``: pass when the value is within the limit, else fail (the interval is
    ignored). ``guard-banded``: pass when the upper confidence bound is within the limit,
    fail when the lower bound is beyond it, indeterminate when the interval straddles it.
    ``strict``: pass only when the upper bound is within the limit, fail otherwise.
    A figure that could not be computed is indeterminate under every rule.
    """
    if value is None:
        return INDETERMINATE
    if rule == "simple":
        return "pass" if value <= limit else "fail"
    if high is None or low is None:
        return INDETERMINATE
    if high <= limit:
        return "pass"
    if rule == "strict" or low > limit:
        return "fail"
    return INDETERMINATE


class Verdicted(Protocol):
    """A graded figure: its verdict at each grade that limits it."""

    @property
    def verdicts(self) -> Mapping[str, str]: ...


def assign_grade(figures: Sequence[Verdicted], grades: tuple[str, ...], reject: str
                 ) -> tuple[str, str, str | None]:
    """(grade, deciding grade, could_reach) of an axis from its figures' verdicts.

    The grade is the best grade at which every limited figure passes; when none does and
    some grade had no fail but an indeterminate verdict, the axis is ``indeterminate``;
    otherwise it is ``reject``.
    """
    first_open: str | None = None
    for grade in grades:
        verdicts = [f.verdicts[grade] for f in figures if grade in f.verdicts]
        if all(v == "pass" for v in verdicts):
            return grade, grade, first_open
        if "fail" not in verdicts and first_open is None:
            first_open = grade
    if first_open is not None:
        return INDETERMINATE, first_open, None
    return reject, grades[-1], None


def grade_rank(grade: str, profile: Profile) -> int:
    """Order of grades, best first: the profile's grades, then indeterminate, then reject."""
    if grade in profile.grades:
        return profile.grades.index(grade)
    return len(profile.grades) + (0 if grade == INDETERMINATE else 1)


# --- figures -------------------------------------------------------------------------------


def _z(confidence: float) -> float:
    return float(stats.norm.ppf(0.5 + confidence / 2))


def _chi2_scaled(value: float, edf: float, confidence: float) -> tuple[float, float]:
    """Interval of a deviation ``value`` whose variance has ``edf`` degrees of freedom."""
    low, high = chi2_interval(1.0, edf, confidence)
    return value * math.sqrt(float(low)), value * math.sqrt(float(high))


def bias_interval(x: np.ndarray, confidence: float) -> Interval:
    """``|mean|`` (deg/h) of the present samples of a rate record (deg/s; NaN where a
    sample is missing) with its batch-means interval. A long record (a memmap) is read a
    block at a time (:mod:`analysis.blocks`): the same numbers, bit for bit where it has
    no gap."""
    if blocks.is_long(len(x)):
        mean = blocks.nan_mean(x) * S_PER_H
        means = blocks.finite_batch_means(x, BIAS_BATCHES) * S_PER_H
    else:
        x = x[np.isfinite(x)]
        mean = float(np.mean(x)) * S_PER_H
        size = len(x) // BIAS_BATCHES
        means = x[: size * BIAS_BATCHES].reshape(BIAS_BATCHES, size).mean(axis=1) * S_PER_H
    half = float(stats.t.ppf(0.5 + confidence / 2, BIAS_BATCHES - 1)) * float(
        np.std(means, ddof=1)) / math.sqrt(BIAS_BATCHES)
    low, high = mean - half, mean + half
    if low <= 0 <= high:
        return Interval(abs(mean), 0.0, max(-low, high), "interval includes zero bias")
    return Interval(abs(mean), min(abs(low), abs(high)), max(abs(low), abs(high)))


def _readoff_interval(analysis: AxisAnalysis, name: str, confidence: float) -> Interval:
    allan = analysis.allan
    if name == "arw":
        r = arw_readoff(allan, analysis.fit, zones=analysis.zones)
        where = f"tau {r.tau_low_s:.3g}-{r.tau_high_s:.3g} s" if r.tau_low_s is not None else ""
    else:
        r = bias_instability_readoff(allan, zones=analysis.zones)
        where = f"at tau {r.tau_low_s:.3g} s" if r.tau_low_s is not None else ""
    if r.value is None:
        return Interval(None, None, None, r.note)
    scale = BIAS_INSTABILITY_FACTOR if name == "adev_min" else 1.0
    low, high = r.interval(confidence)
    assert low is not None and high is not None
    return Interval(r.value * scale, low * scale, high * scale, r.note or where)


def _fit_interval(fit: NoiseCoefficients, term: str, confidence: float) -> Interval:
    value, err = fit.values[term], fit.stderr[term]
    if value is None:
        why = "negative variance term" if term in fit.negative_terms else "not fitted"
        return Interval(None, None, None, f"not estimable ({why})")
    if err is None or not math.isfinite(err):
        return Interval(value, None, None, "no standard error")
    half = _z(confidence) * err
    return Interval(value, max(value - half, 0.0), value + half)


def figure_interval(name: str, x: np.ndarray, analysis: AxisAnalysis, confidence: float, *,
                    source: str = DEFAULT_FIGURE_SOURCE) -> Interval:
    """A figure (canonical unit) with its interval from one axis' rate (deg/s) and analysis.

    ``x`` is the rate the analysis worked on (:attr:`AxisAnalysis.rate_deg_s`: NaN where a
    sample is missing, spikes removed, Earth rate taken off where the bench gives it).
    ``source`` (``"read-off"`` or ``"fit"``) says where ``arw`` and ``bias_instability``
    come from (the profile's ``[grading] figure_source``).
    """
    average_s = bias_stability_average_s(name)
    if average_s is not None:
        bs = bias_stability(x, analysis.sample_rate_hz, average_s,
                            white_level=white_level(analysis.allan))
        if bs.value_deg_h is None:
            return Interval(
                None, None, None, f"only {bs.n_averages} averages of {average_s:g} s, needs 3"
            )
        edf = bs.n_averages - 1 if bs.edf is None else bs.edf
        low, high = _chi2_scaled(bs.value_deg_h, edf, confidence)
        partial = (f", {bs.missing_share:.1%} of their samples missing, edf {edf:.3g}"
                   if bs.missing_share else "")
        return Interval(bs.value_deg_h, low, high, f"{bs.n_averages} averages{partial}")
    if name == "bias":
        b = bias_interval(x, confidence)
        removed = analysis.figures.earth_rate_removed_deg_h
        earth = (
            "Earth rate not removed"
            if removed is None
            else f"Earth rate {removed:+.4g} deg/h removed"
        )
        return replace(b, note="; ".join(t for t in (b.note, earth) if t))
    if name in ("arw", "bias_instability") and source == "fit":
        return _fit_interval(analysis.fit, _FIT_TERM[f"{name}_fit"], confidence)
    if name in ("arw", "bias_instability", "adev_min"):
        return _readoff_interval(analysis, name, confidence)
    return _fit_interval(analysis.fit, _FIT_TERM[name], confidence)


def grade_figure(spec: FigureSpec, interval: Interval, profile: Profile,
                 alternatives: tuple[Reading, ...] = ()) -> FigureResult:
    """Convert a canonical interval to the spec's unit and decide it at every limited grade,
    safely over the ``alternatives`` (other readings, canonical unit) when there are any."""
    factor = spec.unit_factor

    def conv(v: float | None) -> float | None:
        return None if v is None or not math.isfinite(v) else v / factor

    value, low, high = conv(interval.value), conv(interval.low), conv(interval.high)
    readings = [(value, low, high), *((conv(r.value), conv(r.low), conv(r.high))
                                      for r in alternatives)]
    verdicts = {g: safe_verdict([decide(*r, limit, profile.rule) for r in readings])
                for g, limit in spec.limits.items()}
    note = "; ".join(t for t in (interval.note, readings_note(alternatives, spec.unit, factor))
                     if t)
    return FigureResult(spec, value, low, high, verdicts, note, alternatives)


# --- runs ----------------------------------------------------------------------------------


def _axis_token(name: str) -> str:
    return re.split(r"[_\-. ]", name.lower())[-1]


def match_axes(profile_axes: tuple[str, ...], record_axes: tuple[str, ...]) -> dict[str, int]:
    """Column index of each profile axis in a record: by name, by last name token (``gyro_x``
    is ``x``), or one to one when both have a single axis.

    Raises
    ------
    GradingError
        When an axis of the profile is not in the record.
    """
    out: dict[str, int] = {}
    tokens = [_axis_token(a) for a in record_axes]
    for axis in profile_axes:
        if axis in record_axes:
            out[axis] = record_axes.index(axis)
        elif tokens.count(axis.lower()) == 1:
            out[axis] = tokens.index(axis.lower())
        elif len(profile_axes) == 1 and len(record_axes) == 1:
            out[axis] = 0
        else:
            raise GradingError(f"the profile grades axis {axis!r}, the record has "
                               f"{', '.join(record_axes)}")
    return out


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


def grade_unit(unit: UnitRun, profile: Profile, bench: Bench | None = None) -> UnitGrade:
    """Grade one unit of a run with ``profile`` (warm-up discarded, every axis the profile names).

    ``bench`` gives the latitude and axis directions whose Earth rate the bias is reported
    without (:mod:`station.model.bench`).

    Raises
    ------
    GradingError
        When the record is too short after the warm-up or lacks a profile axis.
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
    columns = match_axes(profile.axes, record.axis_names)
    trimmed = RateRecord(
        take_columns(kept.rate_deg_s, list(columns.values())),
        fs,
        tuple(columns),
        record.source,
        kept.temperature_c,
        kept.sample_index,
    )
    notes = []
    if unit.model and unit.model != profile.model:
        notes.append(f"unit model {unit.model!r} differs from the profile's {profile.model!r}")
    if record.duration_s < profile.duration_s * 0.99:
        notes.append(f"record {record.duration_s:.0f} s is shorter than the profile's test "
                     f"({profile.duration_s:.0f} s)")
    if trimmed.missing_samples:
        notes.append(
            f"{trimmed.missing_samples} samples missing in gaps after the warm-up: no Allan "
            "difference or average straddles a gap"
        )
    if profile.sample_rate_hz and abs(fs - profile.sample_rate_hz) > 1e-6 * fs:
        notes.append(f"sample rate {fs:g} Hz, profile says {profile.sample_rate_hz:g} Hz")
    axes = []
    for analysis in analyze_record(trimmed, method=profile.fit_method, bench=bench):
        x = analysis.rate_deg_s
        assert x is not None
        z, source = _z(profile.confidence), profile.figure_source
        figures = tuple(
            grade_figure(
                spec,
                figure_interval(spec.name, x, analysis, profile.confidence, source=source),
                profile,
                () if (term := fit_term(spec.name, source)) is None
                else alternative_readings(analysis.fit, term, z),
            )
            for spec in profile.figures
        )
        grade, deciding, could = assign_grade(figures, profile.grades, profile.reject)
        axes.append(AxisGrade(analysis.name, grade, deciding, figures, analysis, could,
                              axis_review(analysis, profile)))
    worst = max(axes, key=lambda a: grade_rank(a.grade, profile)).grade
    return UnitGrade(unit, worst, tuple(axes), profile.warmup_s if profile.warmup_s > 0 else 0.0,
                     tuple(notes))


def grade_run(run: RunInfo, profile: Profile, *, units: tuple[str, ...] = (),
              bench: Bench | None = None) -> RunGrade:
    """Grade every unit of ``run`` (or those named in ``units``) with ``profile``.

    ``bench`` defaults to the one the run file recorded (none for a CSV record). Works
    on any stored run: nothing here talks to a device.
    """
    chosen = [run.unit(u) for u in units] if units else list(run.units)
    bench = bench if bench is not None else bench_from_json(run.metadata.bench)
    graded = tuple(grade_unit(u, profile, bench) for u in chosen)
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
