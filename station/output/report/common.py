"""What every spec-sheet format shows, computed once: header, figure rows, event summary.

The format writers (:mod:`~station.output.report.pdf`, :mod:`~station.output.report.html`,
:mod:`~station.output.report.json_report`, :mod:`~station.output.report.csv_report`) lay these out;
none of
them computes a figure.
"""

from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from analysis.allan import blocks
from analysis.units.conversions import DEG_FAMILY, S_PER_H, UnitFamily
from station.evaluation.grading import AxisGrade, RunGrade, UnitGrade
from station.model.kinds import Verdict
from station.model.runs import UnitRun
from station.model.sheet_header import station_name

#: How many individual events a report lists before it only counts them.
MAX_EVENTS_LISTED = 12


def fmt(value: float | None, digits: int = 4) -> str:
    """A number for a table: ``digits`` significant digits, ``-`` when missing."""
    return "-" if value is None else f"{value:.{digits}g}"


def fmt_interval(low: float | None, high: float | None) -> str:
    """``[low, high]`` or ``-``."""
    return "-" if low is None or high is None else f"[{fmt(low, 3)}, {fmt(high, 3)}]"


@dataclass(frozen=True)
class FigureRow:
    """One line of a spec sheet's figures table (values in ``unit``)."""

    axis: str
    name: str
    label: str
    unit: str
    value: float | None
    ci_low: float | None
    ci_high: float | None
    limit: float | None
    grade: str
    verdict: Verdict | None
    note: str


def figure_rows(axis: AxisGrade, family: UnitFamily = DEG_FAMILY) -> list[FigureRow]:
    """Rows of one axis: graded figures with the deciding grade's limit, then informational ones
    (values in ``family``)."""
    rows = []
    for f in sorted(axis.figures, key=lambda f: not f.spec.graded):
        graded, unit = f.spec.graded, f.spec.unit
        rows.append(
            FigureRow(
                axis.axis,
                f.name,
                f.spec.label,
                family.label(unit),
                family.value(f.value, unit),
                family.value(f.ci_low, unit),
                family.value(f.ci_high, unit),
                family.value(f.spec.limits.get(axis.deciding_grade), unit) if graded else None,
                axis.deciding_grade if graded else "",
                f.verdicts.get(axis.deciding_grade, "pass") if graded else None,
                f.note,
            )
        )
    return rows


def analysis_lines(unit: UnitGrade, family: UnitFamily = DEG_FAMILY) -> list[str]:
    """What the analysis did to the record, one line per topic: review flags first, then
    spikes, gaps, Earth rate, each axis' tones and the tau zones the fit and read-offs leave out
    (rates in ``family``)."""
    axes = unit.axes
    rate = family.label("deg/h")
    review = [f"REVIEW {line}" for line in unit.review]
    spikes = []
    for a in axes:
        o = a.analysis.outliers
        if o.count and o.detection is not None:
            largest = max(o.detection.spikes, key=lambda sp: abs(sp.size))
            size = (f"{largest.size:+.3g} m/s^2" if a.analysis.accel is not None else
                    f"{family.value(largest.size * S_PER_H, 'deg/h'):+.3g} {rate}")
            spikes.append(f"{a.axis} {o.count} {'removed' if o.removed else 'kept'} (largest "
                          f"{size})")
        else:
            spikes.append(f"{a.axis} {o.text()}")
    lines = ["spikes: " + ", ".join(spikes)]
    gaps = axes[0].analysis.gaps if axes else None
    if gaps is not None and gaps.count:
        lines.append(f"gaps: {gaps.text()} missing; no Allan difference or average straddles a gap")
    removed = [(a.axis, a.analysis.figures.earth_rate_removed_deg_h) for a in axes
               if a.analysis.accel is None]
    if removed and all(v is None for _, v in removed):  # none: accelerometers only
        notes = [
            n
            for n in (axes[0].analysis.figures.notes if axes else ())
            if n.startswith("Earth rate")
        ]
        lines.append(notes[0] if notes else "Earth rate not removed from the bias")
    elif removed:
        lines.append("Earth rate removed from the bias: " + ", ".join(
            f"{axis} " + ("not removed" if v is None else f"{family.value(v, 'deg/h'):+.4g} {rate}")
            for axis, v in removed))
    for a in axes:
        series_unit = "m/s^2" if a.analysis.accel is not None else "deg/s"
        lines += [f"{a.axis}: {t.describe(series_unit)}" for t in a.analysis.tones]
        lines += [
            f"{a.axis}: fit and read-offs leave out tau {z.tau_low_s:.3g}-{z.tau_high_s:.3g} s "
            f"({z.kind})"
            for z in a.analysis.zones
        ]
    # a figure under the floor of the link's LSB: why its verdicts are indeterminate
    unresolved = [
        f"NOT RESOLVED {a.axis} {f.spec.label}: "
        + f.note.split("; ")[0].removeprefix("not resolved: ")
        for a in axes for f in a.figures if f.spec.graded and not f.resolved]
    return review + unresolved + ambiguity_lines(unit, family) + lines


def ambiguity_lines(unit: UnitGrade, family: UnitFamily = DEG_FAMILY) -> list[str]:
    """One line per fitted figure whose record allows other readings: the printed value
    (of the reading the record supports best) with its interval, which covers every
    reading, and the others with their own intervals (values in ``family``); the sheets
    and the TUI show them."""
    out = []
    for a in unit.axes:
        for f in a.figures:
            if not f.alternatives:
                continue
            u, factor = f.spec.unit, f.spec.unit_factor
            others = "; ".join(
                f"{_num(family.value(_over(r.value, factor), u))} "
                f"[{_num(family.value(_over(r.low, factor), u))}, "
                f"{_num(family.value(_over(r.high, factor), u))}] "
                f"(terms {r.terms})" for r in f.alternatives if r.value is not None)
            out.append(
                f"AMBIGUOUS {a.axis} {f.spec.label}: printed the reading the record supports "
                f"best (terms {f.terms or a.analysis.fit.terms}), "
                f"{_num(family.value(f.value, u))} [{_num(family.value(f.ci_low, u))}, "
                f"{_num(family.value(f.ci_high, u))}] {family.label(u)}, the interval "
                f"covering every reading; the record also allows {others}; verdict "
                f"{f.verdicts.get(a.deciding_grade, 'not limited')}, safe for every reading")
    return out


def _over(v: float | None, factor: float) -> float | None:
    return None if v is None else v / factor


def _num(v: float | None) -> str:
    return "-" if v is None else f"{v:.3g}"


def to_the_second(utc: str) -> str:
    """An ISO 8601 time to the second (``2026-05-01T10:22:03.123456+00:00`` ->
    ``2026-05-01 10:22:03``, in UTC); text that is not a time comes back as it is."""
    try:
        t = datetime.fromisoformat(utc.replace("Z", "+00:00"))
    except ValueError:
        return utc
    if t.tzinfo is not None:
        t = t.astimezone(UTC)
    return t.strftime("%Y-%m-%d %H:%M:%S")


def temperature_text(unit: UnitGrade) -> str:
    """The test temperature from the unit's channel: mean and range (degC), or "not recorded"."""
    temp = unit.unit.record.temperature_c
    if temp is None or not blocks.any_where(temp, np.isfinite):
        return "not recorded (no temperature channel)"
    low, high = np.inf, -np.inf
    for a, b in blocks.spans(0, len(temp)):  # a long record's channel: a block at a time
        t = np.asarray(temp[a:b])
        t = t[np.isfinite(t)]
        blocks.release(temp)
        if t.size:
            low, high = min(low, float(t.min())), max(high, float(t.max()))
    mean = float(blocks.finite_batch_means(temp, 1)[0]) if blocks.is_long(len(temp)) \
        else float(temp[np.isfinite(temp)].mean())
    return f"{mean:.1f} degC (mean; {low:.1f} to {high:.1f} degC)"


def header_fields(graded: RunGrade, unit: UnitGrade) -> list[tuple[str, str]]:
    """(label, text) pairs of a spec sheet's header (the test house's from ``graded.sheet``)."""
    run, p, u, sheet = graded.run, graded.profile, unit.unit, graded.sheet
    duration = u.record.duration_s
    recorded = (f" (recorded with {run.metadata.software_version})"
                if run.metadata.software_version else "")
    return [
        *([("Company", sheet.company)] if sheet is not None and sheet.company else []),
        ("Model", u.model or p.model),
        ("Serial number", u.serial_number or f"({u.unit_id})"),
        ("Test date (UTC)", to_the_second(run.start_utc) if run.start_utc else "not recorded"),
        (
            "Duration",
            f"{duration / 3600:.3g} h ({duration:.0f} s), warm-up {unit.warmup_discarded_s:g} s "
            f"discarded",
        ),
        ("Sample rate", f"{u.record.sample_rate_hz:g} Hz"),
        ("Temperature", temperature_text(unit)),
        *([("Conditions", sheet.conditions)] if sheet is not None and sheet.conditions else []),
        ("Station", station_name(sheet, run.metadata.station_host)),
        ("Operator", run.metadata.operator or "-"),
        ("Lot", run.metadata.lot or "-"),
        ("Software version", f"{graded.software_version}{recorded}"),
        ("Profile", f"{p.ref} ({Path(p.path).name}, sha256 {p.sha256[:8]})"),
        ("Decision rule", f"{p.rule}, {p.confidence:.0%} confidence intervals"),
        ("Graded (UTC)", to_the_second(graded.graded_utc)),
        ("Run file", Path(run.path).name),
    ]


#: The sheet's statement of the Allan plot's bias-instability limit line (and of B).
LIMIT_LINE_NOTE = (
    "Allan plot: the bias-instability limit is drawn at 0.664 x the limit, the "
    "flat Allan deviation of a unit at the limit; B = sigma_min / 0.664 (IEEE Std 952 "
    "Annex C; imu_utils and kalibr_allan report sigma_min itself)"
)


#: The figures table's caption: which figures are the specification.
SPEC_CAPTION = ("Specification: the figures graded against the profile's limits of the grade "
                "shown. info: shown for information, not graded.")


@dataclass(frozen=True)
class EventSummary:
    """A unit's event log in brief: counts per kind, gaps and samples lost, the first events."""

    counts: dict[str, int]
    n_gaps: int
    missing_samples: int
    listed: tuple[str, ...]
    has_log: bool
    stop_reason: str
    interrupted: bool

    def lines(self, *, brief: bool = False) -> list[str]:
        """Text lines for reports; ``brief`` leaves out the individual events."""
        if not self.has_log:
            out = ["no event log (a record without run metadata, e.g. CSV)"]
        else:
            kinds = ", ".join(f"{k} {n}" for k, n in sorted(self.counts.items())) or "none"
            out = [
                f"events: {kinds}",
                f"gaps: {self.n_gaps}, samples missing: {self.missing_samples}",
            ]
            out += [] if brief else list(self.listed)
        if self.stop_reason or self.interrupted:
            out.append(
                f"run stop: {self.stop_reason or '-'}{' (interrupted)' if self.interrupted else ''}"
            )
        return out

    def as_json(self) -> dict[str, object]:
        """JSON form."""
        return {
            "has_log": self.has_log,
            "counts": dict(self.counts),
            "gaps": self.n_gaps,
            "missing_samples": self.missing_samples,
            "stop_reason": self.stop_reason,
            "interrupted": self.interrupted,
        }


def event_summary(unit: UnitRun, graded: RunGrade) -> EventSummary:
    """Summarize a unit's event log (gaps, resyncs, reconnects, CRC errors, ...)."""
    counts: Counter[str] = Counter()
    for e in unit.events:
        counts[e.kind] += e.count
    listed = tuple(
        f"{e.time_s:9.1f} s  {e.kind}"
        + (f" x{e.count}" if e.count != 1 else "")
        + (f", {e.missing_samples} samples missing" if e.missing_samples else "")
        + (f" ({e.detail})" if e.detail else "")
        for e in unit.events[:MAX_EVENTS_LISTED]
    )
    if len(unit.events) > MAX_EVENTS_LISTED:
        listed += (f"... and {len(unit.events) - MAX_EVENTS_LISTED} more events",)
    has_log = bool(unit.events) or Path(graded.run.path).suffix.lower() in (".h5", ".hdf5")
    return EventSummary(
        dict(counts),
        unit.n_gaps,
        unit.missing_samples,
        listed,
        has_log,
        graded.run.stop_reason,
        graded.run.interrupted,
    )


def report_stem(graded: RunGrade) -> str:
    """File stem of a run's report: ``<run file stem>_<profile name>``, filesystem-safe."""
    stem = Path(graded.run.path).name.split(".")[0]
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", f"{stem}_{graded.profile.name}")


@dataclass(frozen=True)
class AxisLine:
    """One axis' grade under the figures table (``could_reach``: the better grade it was
    indeterminate at, "" if none)."""

    axis: str
    grade: str
    could_reach: str

    def text(self) -> str:
        """``axis x A``, ``axis x B, indeterminate at A``, ``axis x indeterminate at B``."""
        if not self.could_reach:
            return f"axis {self.axis} {self.grade}"
        if self.grade == "indeterminate":
            return f"axis {self.axis} indeterminate at {self.could_reach}"
        return f"axis {self.axis} {self.grade}, indeterminate at {self.could_reach}"


#: The analysis lines the verdict counts: (prefix, what one is, what several are).
FLAGGED = (
    ("REVIEW", "review item", "review items"),
    ("NOT RESOLVED", "figure under the link's resolution", "figures under the link's resolution"),
    ("AMBIGUOUS", "figure of which the record allows other readings (printed: the interval "
                  "covering all)", "figures of which the record allows other readings "
                                   "(printed: the interval covering all)"),
)


@dataclass(frozen=True)
class UnitSheet:
    """Everything one unit's spec sheet shows, for each format to lay out (PDF, HTML)."""

    unit_id: str
    model: str
    serial: str
    grade: str
    rejected: bool
    header: list[tuple[str, str]]
    rows: list[FigureRow]
    axes: list[AxisLine]
    events: EventSummary
    analysis: list[str]
    notes: tuple[str, ...]
    #: The test as it was run (the footer of every page): :func:`conducted_test`
    test: str = ""
    #: The figure notes the test record lists beside the analysis (spikes per axis)
    figure_notes: tuple[str, ...] = ()

    @property
    def title(self) -> str:
        """``Gyro spec sheet: <model> s/n <serial>``."""
        return f"Gyro spec sheet: {self.model} s/n {self.serial}"

    @property
    def spec_rows(self) -> list[FigureRow]:
        """The figure lines of the specification: those the profile grades."""
        return [r for r in self.rows if r.verdict is not None]

    @property
    def info_rows(self) -> list[FigureRow]:
        """The figures shown for information, not graded (e.g. the Allan read-off of a
        bias instability whose specification is the fitted B)."""
        return [r for r in self.rows if r.verdict is None]

    def record_sections(self) -> list[tuple[str, list[str]]]:
        """The test record, the sheet's second part: (heading, lines) of its events
        (each listed), the analysis (review items, unresolved and ambiguous figures,
        spikes, gaps, Earth rate, tones, left-out tau zones), the notes and the plot's
        convention; a heading without lines is left out."""
        sections = [("Events", self.events.lines()),
                    ("Analysis", [*self.analysis, *self.figure_notes]),
                    ("Notes", list(self.notes)),
                    ("Conventions", [LIMIT_LINE_NOTE])]
        return [(heading, lines) for heading, lines in sections if lines]

    def verdict_lines(self) -> list[str]:
        """The verdict under the plots: the unit's grade, each axis' grade, and what the
        test record holds that bears on it (review items, figures other readings of the
        record allow, figures under the link's resolution)."""
        out = [f"Verdict: grade {self.grade}; " + "; ".join(map(AxisLine.text, self.axes))]
        said = []
        for prefix, one, many in FLAGGED:
            n = sum(line.startswith(prefix) for line in self.analysis)
            if n:
                said.append(f"{n} {one if n == 1 else many}")
        out.append(("Flagged: " + "; ".join(said) + ". " if said else "")
                   + "Events, gaps, analysis and notes: the test record at the end of this "
                     "sheet.")
        return out


def unit_sheet(graded: RunGrade, unit: UnitGrade) -> UnitSheet:
    """What the spec sheet of ``unit`` shows (the serial number falls back to the unit id)."""
    u = unit.unit
    return UnitSheet(
        u.unit_id,
        u.model or graded.profile.model,
        u.serial_number or u.unit_id,
        unit.grade,
        unit.grade == graded.profile.reject,
        header_fields(graded, unit),
        [r for axis in unit.axes for r in figure_rows(axis, graded.output_units)],
        [AxisLine(a.axis, a.grade, a.could_reach or "") for a in unit.axes],
        event_summary(u, graded),
        analysis_lines(unit, graded.output_units),
        unit.notes,
        conducted_test(graded, unit),
        tuple(f"{a.axis}: {n}" for a in unit.axes for n in a.analysis.figures.notes
              if n.startswith("spikes:")),
    )


def duration_text(seconds: float) -> str:
    """A test's duration in the unit that reads best: ``12 h``, ``20.2 min``, ``45 s``."""
    if seconds >= 3600:
        return f"{seconds / 3600:.3g} h"
    if seconds >= 60:
        return f"{seconds / 60:.3g} min"
    return f"{seconds:.3g} s"


def conducted_test(graded: RunGrade, unit: UnitGrade) -> str:
    """The test as it was run, from the record (not from the profile's description, which
    says what the profile asks for): ``12 h static test at 10 Hz (warm-up 300 s
    discarded), profile VG951@1, guard-banded``; a test sequence's run says its sequence."""
    record, p = unit.unit.record, graded.profile
    kind = (f"test sequence {unit.sequence.sequence}" if unit.sequence is not None
            else "static test")
    return (f"{duration_text(record.duration_s)} {kind} at {record.sample_rate_hz:g} Hz "
            f"(warm-up {unit.warmup_discarded_s:g} s discarded), profile {p.ref}, "
            f"{p.rule} at {p.confidence:.0%}")
