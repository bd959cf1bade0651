"""The figures of a test sequence per unit, each with its interval, graded against the profile.

From the segments placed in time (:mod:`station.evaluation.sequence_cycles`), for each
unit and each axis the profile grades:

``turn_on_repeatability``
    standard deviation of the per-switch-on mean biases, each after ``bias_after_s`` from
    power-on; chi-square interval on ``N - 1`` degrees of freedom
    (:func:`analysis.sequences.turn_on.turn_on_repeatability`). Every switch-on counts,
    one a resume made too (a unit powered again takes a new turn-on bias); where the
    switch-ons' biases were measured at different temperatures (a temperature test
    resumed), each is its bias at the temperature fit's reference temperature.
``turn_on_time``
    switch-on to the first valid sample, per switch-on the recorder heard; the mean with
    its interval (log-normal: a time's interval never goes below 0, see
    :func:`analysis.sequences.cycle_stats.lognormal_mean_interval`), the spread and the
    largest.
``warmup_time``
    switch-on to the time the bias trend enters ``+- warmup_band_deg_h`` of the settled
    bias for good (:func:`analysis.sequences.turn_on.warmup_curve`), per switch-on; mean, interval,
    spread. The DAVAR warm-up detector (:func:`analysis.davar.warmup.detect_warmup`) is run on
    the same record: when the noise settles later than the bias, a note says so.
``temperature_coefficient``
    the slope of bias on temperature (linear weighted fit; a quadratic too with four
    points or more), from plateaus or ramps (:mod:`analysis.sequences.temperature_sensitivity`);
    graded on its magnitude. Points of different switch-ons (a resume that switched the
    unit on again) each get their own bias in the fit, and a note says so.
``hysteresis``
    the largest up-minus-down bias difference at a common temperature, within a
    switch-on.

Each figure is reported per unit as the worst of its axes. A figure the sequence did not
measure is None (``null`` in JSON) and, when limited, indeterminate.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from analysis.davar.estimators import dynamic_allan_variance
from analysis.davar.warmup import detect_warmup
from analysis.distributions import normal_ppf
from analysis.errors import AnalysisError
from analysis.sequences.cycle_stats import CycleSummary, summarize_cycles
from analysis.sequences.temperature_sensitivity import (
    Hysteresis,
    TemperatureFit,
    TemperaturePoint,
    fit_temperature_sensitivity,
    hysteresis,
    plateau_point,
    ramp_points,
)
from analysis.sequences.turn_on import (
    CycleBias,
    Repeatability,
    WarmupCurve,
    cycle_bias,
    turn_on_repeatability,
    warmup_curve,
)
from station.evaluation.decision import assign_grade, decide, match_axes
from station.evaluation.sequence_cycles import SegmentView, unit_segments
from station.evaluation.sequence_plateaus import Plateau, plateau_analyses, temperature_span_c
from station.model.kinds import INDETERMINATE, Verdict
from station.model.profiles import Profile
from station.model.sequence_runs import SequenceRun
from station.model.sequences import SequenceFigureSpec, SequenceSpec

#: JSON keys of the figures every unit reports (with ``_ci`` companions), canonical units.
FIGURE_KEYS = ("turn_on_repeatability_deg_h", "warmup_time_s", "turn_on_time_s",
               "temperature_coefficient_deg_h_per_c")


@dataclass(frozen=True)
class CycleFigures:
    """What one switch-on of a unit gave.

    Attributes
    ----------
    power_cycle : int
        1-based switch-on count.
    segment : str
        The segment file its figures come from.
    turn_on_time_s : float or None
        Switch-on to the first valid sample, s (None: not heard from the switch-on).
    biases : dict
        Per axis, the mean bias after the warm-up (None: the record ends before).
    warmups : dict
        Per axis, the bias trend and warm-up time (None: not measured).
    davar_settled_s : dict
        Per axis, the time (s since switch-on) the DAVAR detector finds the noise settled.
    interrupted : bool
        Its record was interrupted.
    by_resume : bool
        A resume switched the unit on (no ``power_on`` step asked for it; its turn-on time
        is not heard).
    """

    power_cycle: int
    segment: str
    turn_on_time_s: float | None
    biases: dict[str, CycleBias | None]
    warmups: dict[str, WarmupCurve | None]
    davar_settled_s: dict[str, float | None]
    interrupted: bool = False
    by_resume: bool = False

    def warmup_time_s(self, axis: str) -> float | None:
        """The axis' warm-up time, s since switch-on (None: not measured, or not settled)."""
        w = self.warmups.get(axis)
        return None if w is None else w.warmup_time_s


@dataclass(frozen=True)
class AxisSequence:
    """The sequence figures of one axis of a unit."""

    axis: str
    repeatability: Repeatability
    warmup: CycleSummary
    points: tuple[TemperaturePoint, ...]
    linear: TemperatureFit | None
    quadratic: TemperatureFit | None
    hysteresis: Hysteresis | None


@dataclass(frozen=True)
class SequenceFigureResult:
    """A graded sequence figure, in the profile's unit for it."""

    spec: SequenceFigureSpec
    value: float | None
    ci_low: float | None
    ci_high: float | None
    verdicts: dict[str, Verdict]
    note: str = ""

    def as_json(self, grade: str | None) -> dict[str, object]:
        """The figure with the limit and verdict of ``grade``."""
        return {"label": self.spec.label, "unit": self.spec.unit, "value": self.value,
                "ci_low": self.ci_low, "ci_high": self.ci_high,
                "limit": self.spec.limits.get(grade) if grade else None,
                "verdict": self.verdicts.get(grade, "pass") if grade else None,
                "limits": dict(self.spec.limits), "verdicts": dict(self.verdicts),
                "note": self.note}


@dataclass(frozen=True)
class Figure:
    """A figure in its canonical unit with its interval, and the axis it is the worst of."""

    value: float | None = None
    low: float | None = None
    high: float | None = None
    axis: str = ""


@dataclass(frozen=True)
class UnitSequence:
    """Every sequence figure of one unit, graded.

    Attributes
    ----------
    unit_id : str
        The unit.
    sequence : str
        The sequence's name.
    cycles : tuple of CycleFigures
        Per switch-on.
    turn_on : CycleSummary
        Turn-on times across switch-ons, s.
    axes : tuple of AxisSequence
        Per axis.
    figures : dict
        The canonical figures (:data:`FIGURE_KEYS` and more), worst axis each.
    graded : tuple of SequenceFigureResult
        The profile's sequence figures with their verdicts.
    grade, deciding_grade : str
        The grade the sequence figures alone give, and the grade whose limits decided it
        ("" when the profile limits none).
    confidence : float
        Two-sided level of every interval.
    notes : tuple of str
        What a reader should know (interruptions, figures not measured, noisy trends).
    plateaus : tuple of Plateau
        The Allan analysis of each temperature plateau, per axis
        (:mod:`station.evaluation.sequence_plateaus`).
    """

    unit_id: str
    sequence: str
    cycles: tuple[CycleFigures, ...]
    turn_on: CycleSummary
    axes: tuple[AxisSequence, ...]
    figures: dict[str, Figure]
    graded: tuple[SequenceFigureResult, ...]
    grade: str
    deciding_grade: str
    confidence: float
    notes: tuple[str, ...] = field(default_factory=tuple)
    plateaus: tuple[Plateau, ...] = ()

    def as_json(self) -> dict[str, object]:
        """The ``sequence_figures`` object of ``station grade --json``."""
        out: dict[str, object] = {"sequence": self.sequence, "confidence": self.confidence,
                                  "cycles": len(self.cycles)}
        for key, fig in self.figures.items():
            out[key] = fig.value
            # an upper bound the values cannot give (inf) is null: "no upper bound"
            out[f"{key}_ci"] = (None if fig.low is None or fig.high is None
                                else [fig.low, fig.high if math.isfinite(fig.high) else None])
        out["turn_on_time_max_s"] = self.turn_on.maximum
        out["grade"] = self.grade or None
        out["deciding_grade"] = self.deciding_grade or None
        out["graded"] = {g.spec.name: g.as_json(self.deciding_grade or None) for g in self.graded}
        out["per_cycle"] = [{
            "power_cycle": c.power_cycle, "segment": c.segment, "interrupted": c.interrupted,
            "by_resume": c.by_resume,
            "turn_on_time_s": c.turn_on_time_s,
            "bias_deg_h": {a: None if b is None else b.mean_deg_h for a, b in c.biases.items()},
            "bias_stderr_deg_h": {a: None if b is None else b.stderr_deg_h
                                  for a, b in c.biases.items()},
            "warmup_time_s": {a: c.warmup_time_s(a) for a in c.warmups},
            "davar_settled_s": dict(c.davar_settled_s)} for c in self.cycles]
        out["temperature_points"] = {a.axis: [
            {"temperature_c": p.temperature_c, "bias_deg_h": p.bias_deg_h,
             "stderr_deg_h": p.stderr_deg_h, "direction": p.direction, "n_samples": p.n_samples,
             "power_cycle": p.switch_on}
            for p in a.points] for a in self.axes}
        out["notes"] = list(self.notes)
        return out


# --- per switch-on ---------------------------------------------------------------------


def _davar_settled(x: np.ndarray, fs: float, first_s: float) -> float | None:
    """The DAVAR warm-up end (s since switch-on), None when it cannot be judged."""
    if not np.all(np.isfinite(x)) or len(x) < 200:
        return None
    try:
        result = dynamic_allan_variance(x, fs, window_s=len(x) / fs / 5.0, taus="octave",
                                        backend="numpy")
        end = detect_warmup(result).warmup_end_s
    except (AnalysisError, ValueError):
        return None
    return None if end is None else first_s + end


def _combined(biases: list[CycleBias]) -> CycleBias | None:
    """One bias from the attempts of an interrupted record (weighted by their samples)."""
    if not biases:
        return None
    if len(biases) == 1:
        return biases[0]
    n = np.array([b.n_samples for b in biases], dtype=float)
    mean = float(np.sum(n * [b.mean_deg_h for b in biases]) / n.sum())
    errs = [b.stderr_deg_h for b in biases]
    err = (None if any(e is None for e in errs) else
           float(math.sqrt(sum((k * e) ** 2 for k, e in zip(n, errs, strict=True))) / n.sum()))
    return CycleBias(mean, err, int(n.sum()), biases[0].after_s)


def cycle_figures(views: Sequence[SegmentView], columns: dict[str, int], spec: SequenceSpec
                  ) -> list[CycleFigures]:
    """Per switch-on (the profile's and a resume's), the figures of its first recorded
    step (all its attempts since that switch-on)."""
    by_cycle: dict[int, list[SegmentView]] = {}
    for v in views:
        if v.power_cycle is not None:
            by_cycle.setdefault(v.power_cycle, []).append(v)
    out = []
    for cycle, group in sorted(by_cycle.items()):
        first_step = group[0].step.index
        attempts = [v for v in group if v.step.index == first_step]
        latest = max(v.switch_on_wall_s or 0.0 for v in attempts)
        attempts = [v for v in attempts if (v.switch_on_wall_s or 0.0) == latest]
        heard = next((v for v in attempts if v.turn_on_time_s is not None), None)
        biases: dict[str, CycleBias | None] = {}
        warmups: dict[str, WarmupCurve | None] = {}
        davar: dict[str, float | None] = {}
        for axis, col in columns.items():
            parts = []
            for v in attempts:
                assert v.first_s is not None
                try:
                    parts.append(cycle_bias(v.data.record.gridded(col), v.sample_rate_hz,
                                            first_s=v.first_s, after_s=spec.bias_after_s))
                except AnalysisError:
                    continue
            biases[axis] = _combined(parts)
            warmups[axis], davar[axis] = None, None
            if heard is not None and heard.first_s is not None:
                x = heard.data.record.gridded(col)
                if spec.warmup_band_deg_h is not None:
                    try:
                        warmups[axis] = warmup_curve(x, heard.sample_rate_hz,
                                                     first_s=heard.first_s,
                                                     band_deg_h=spec.warmup_band_deg_h,
                                                     average_s=spec.warmup_average_s)
                    except AnalysisError:
                        pass
                davar[axis] = _davar_settled(x, heard.sample_rate_hz, heard.first_s)
        out.append(CycleFigures(cycle, attempts[0].segment.file,
                                None if heard is None else heard.turn_on_time_s, biases,
                                warmups, davar, any(v.segment.interrupted for v in attempts),
                                attempts[0].by_resume))
    return out


# --- temperature -----------------------------------------------------------------------


def temperature_points(views: Sequence[SegmentView], column: int, spec: SequenceSpec
                       ) -> list[TemperaturePoint]:
    """Points of bias against temperature of one axis, each with its switch-on: a plateau
    point per ``record`` step and switch-on whose temperature moves less than
    ``plateau_span_c`` (the parts of a step recorded in several, interrupted and resumed
    without a new switch-on, joined), ramp bins otherwise; the warm-up (``bias_after_s``
    from switch-on) left out."""
    points: list[TemperaturePoint] = []
    by_step: dict[tuple[int, int | None], list[SegmentView]] = {}
    for v in views:
        if v.temperature_c is not None:
            by_step.setdefault((v.step.index, v.power_cycle), []).append(v)
    for (_, switch_on), parts in by_step.items():
        keeps = [v.settled(spec.bias_after_s) for v in parts]
        x = np.concatenate([v.data.record.gridded(column)[k] for v, k in zip(parts, keeps,
                                                                            strict=True)])
        temp = np.concatenate([v.temperature_c[k] for v, k in zip(parts, keeps, strict=True)
                               if v.temperature_c is not None])
        span = temperature_span_c(temp)
        if span is None:
            continue
        try:
            if span < spec.plateau_span_c:
                points.append(plateau_point(x, temp, switch_on=switch_on))
            else:
                points.extend(ramp_points(x, temp, bin_c=spec.ramp_bin_c, switch_on=switch_on))
        except AnalysisError:
            continue
    return points


def _fits(points: list[TemperaturePoint], spec: SequenceSpec, confidence: float
          ) -> tuple[TemperatureFit | None, TemperatureFit | None]:
    """The linear and quadratic fits (None: not measured): a switch-on's points tell the
    slope when they span ``2 * plateau_span_c`` or more; a quadratic from one residual
    degree of freedom on."""
    spans: dict[int | None, tuple[float, float]] = {}
    for p in points:
        low, high = spans.get(p.switch_on, (p.temperature_c, p.temperature_c))
        spans[p.switch_on] = (min(low, p.temperature_c), max(high, p.temperature_c))
    if len(points) < 2 or max(h - lo for lo, h in spans.values()) < 2 * spec.plateau_span_c:
        return None, None
    try:
        linear = fit_temperature_sensitivity(points, order=1, confidence=confidence)
    except AnalysisError:
        return None, None
    quadratic = None
    if len(points) >= len(spans) + 3:
        try:
            quadratic = fit_temperature_sensitivity(points, order=2, confidence=confidence,
                                                    reference_c=linear.reference_c)
        except AnalysisError:
            quadratic = None
    return linear, quadratic


def _turn_on_biases(cycles: Sequence[CycleFigures], axis: str, linear: TemperatureFit | None
                    ) -> list[CycleBias] | None:
    """Each switch-on's bias at the fit's reference temperature, when a temperature fit gave
    every switch-on with a bias its own (a temperature test a resume switched on again:
    the switch-ons' first records were at different temperatures); None otherwise."""
    if linear is None or len(linear.switch_ons) < 2:
        return None
    measured = [c for c in cycles if c.biases.get(axis) is not None]
    if not measured or any(c.power_cycle not in linear.switch_ons for c in measured):
        return None
    out = []
    for c in measured:
        k = linear.switch_ons.index(c.power_cycle)
        own = c.biases[axis]
        assert own is not None
        out.append(CycleBias(linear.intercepts_deg_h[k], linear.intercepts_stderr_deg_h[k],
                             own.n_samples, own.after_s))
    return out


def _switch_on_fit_note(axis: str, linear: TemperatureFit, at_reference: bool) -> str:
    ons = ", ".join(str(s) for s in linear.switch_ons)
    text = (f"axis {axis}: the temperature points come from switch-ons {ons} (a resume "
            f"switched the unit on again, with a new turn-on bias): the fit gives each "
            f"switch-on its own bias and one coefficient ({linear.dof} residual degree(s) "
            f"of freedom)")
    if at_reference:
        text += (f"; the turn-on repeatability compares their biases at "
                 f"{linear.reference_c:.4g} degC")
    return text


# --- the unit --------------------------------------------------------------------------


def _worst(figs: list[Figure]) -> Figure:
    known = [f for f in figs if f.value is not None]
    return max(known, key=lambda f: abs(f.value or 0.0)) if known else Figure()


def _summary_figure(s: CycleSummary, axis: str = "", *, spread: bool = False) -> Figure:
    if spread:
        return Figure(s.std, s.std_low, s.std_high, axis)
    return Figure(s.mean, s.mean_low, s.mean_high, axis)


def _canonical(axes: list[AxisSequence], turn_on: CycleSummary, confidence: float
               ) -> dict[str, Figure]:
    z = float(normal_ppf(0.5 + confidence / 2))
    rep = _worst([Figure(a.repeatability.value_deg_h, a.repeatability.ci_low_deg_h,
                         a.repeatability.ci_high_deg_h, a.axis) for a in axes])
    warm = _worst([_summary_figure(a.warmup, a.axis) for a in axes])
    tempco = _worst([Figure(a.linear.coefficients[1], a.linear.ci_low[1], a.linear.ci_high[1],
                            a.axis) for a in axes if a.linear is not None])
    quad = _worst([Figure(a.quadratic.coefficients[2], a.quadratic.ci_low[2],
                          a.quadratic.ci_high[2], a.axis) for a in axes
                   if a.quadratic is not None])
    hyst = _worst([Figure(a.hysteresis.value_deg_h,
                          max(0.0, a.hysteresis.value_deg_h - z * a.hysteresis.stderr_deg_h),
                          a.hysteresis.value_deg_h + z * a.hysteresis.stderr_deg_h, a.axis)
                   for a in axes if a.hysteresis is not None])
    return {"turn_on_repeatability_deg_h": rep, "warmup_time_s": warm,
            "turn_on_time_s": _summary_figure(turn_on),
            "temperature_coefficient_deg_h_per_c": tempco,
            "temperature_coefficient2_deg_h_per_c2": quad, "hysteresis_deg_h": hyst,
            "warmup_time_spread_s": _worst([_summary_figure(a.warmup, a.axis, spread=True)
                                            for a in axes]),
            "turn_on_time_spread_s": _summary_figure(turn_on, spread=True)}


def _graded(spec: SequenceFigureSpec, fig: Figure, profile: Profile) -> SequenceFigureResult:
    value, low, high = fig.value, fig.low, fig.high
    note = f"axis {fig.axis}" if fig.axis else ""
    if spec.name == "temperature_coefficient" and value is not None:
        value = abs(value)
        if low is not None and high is not None:
            low, high = ((0.0, max(abs(low), abs(high))) if low <= 0 <= high
                         else (min(abs(low), abs(high)), max(abs(low), abs(high))))
    f = spec.unit_factor

    def conv(v: float | None) -> float | None:
        return None if v is None or not math.isfinite(v) else v / f

    value, low, high = conv(value), conv(low), conv(high)
    if value is None:
        note = "not measured by this sequence"
    verdicts: dict[str, Verdict] = {g: decide(value, low, high, limit, profile.rule)
                                for g, limit in spec.limits.items()}
    return SequenceFigureResult(spec, value, low, high, verdicts, note)


_FIGURE_OF = {"turn_on_repeatability": "turn_on_repeatability_deg_h",
              "warmup_time": "warmup_time_s", "turn_on_time": "turn_on_time_s",
              "temperature_coefficient": "temperature_coefficient_deg_h_per_c",
              "hysteresis": "hysteresis_deg_h"}


def _notes(cycles: list[CycleFigures], spec: SequenceSpec, axes: list[AxisSequence],
           n_views: int) -> list[str]:
    notes = []
    interrupted = [c.power_cycle for c in cycles if c.interrupted]
    if interrupted:
        notes.append(f"switch-on(s) {', '.join(map(str, interrupted))}: the record was "
                     f"interrupted and resumed; its bias joins the parts recorded")
    if n_views and not cycles:
        notes.append("no switch-on in the journal before the records: turn-on, warm-up and "
                     "repeatability not measured (the units were not switched)")
    resumed = [c.power_cycle for c in cycles if c.by_resume]
    if resumed:
        notes.append(f"switch-on(s) {', '.join(map(str, resumed))}: made by a resume that "
                     f"found the supply off (no power_on step asked for it): a switch-on of "
                     f"its own, with its own turn-on bias")
    if cycles and any(c.turn_on_time_s is None for c in cycles):
        missed = [c.power_cycle for c in cycles if c.turn_on_time_s is None]
        notes.append(f"switch-on(s) {', '.join(map(str, missed))}: not heard from the "
                     f"switch-on (a record that did not start at power_on)")
    for c in cycles:
        for axis, w in c.warmups.items():
            if w is None:
                continue
            if w.average_noise_deg_h is not None and w.average_noise_deg_h > w.band_deg_h / 5:
                notes.append(f"switch-on {c.power_cycle} axis {axis}: the bias trend's noise "
                             f"({w.average_noise_deg_h:.3g} deg/h) exceeds a fifth of the band: "
                             f"the warm-up time may come out late; raise warmup_average_s")
            d = c.davar_settled_s.get(axis)
            if w.warmup_time_s is not None and d is not None and d > w.warmup_time_s:
                notes.append(f"switch-on {c.power_cycle} axis {axis}: the bias is in its band "
                             f"at {w.warmup_time_s:.4g} s, the noise (DAVAR) settles at "
                             f"{d:.4g} s")
            if w.warmup_time_s is None:
                notes.append(f"switch-on {c.power_cycle} axis {axis}: the bias had not "
                             f"settled in its band by the end of the record")
    reps = [a.repeatability.n_cycles for a in axes]
    if reps and 1 < max(reps) < 5:
        notes.append(f"repeatability from {max(reps)} switch-ons; IEEE Std 952 and 1431 ask "
                     f"for at least 5")
    return notes


def grade_unit_sequence(run: SequenceRun, unit_id: str, profile: Profile,
                        spec: SequenceSpec) -> UnitSequence:
    """Every sequence figure of one unit, graded with ``profile``'s limits for ``spec``."""
    views = unit_segments(run, unit_id)
    confidence = profile.confidence
    columns: dict[str, int] = {}
    if views:
        columns = match_axes(profile.axes, views[0].data.record.axis_names)
    cycles = cycle_figures(views, columns, spec)
    axes = []
    fit_notes: list[str] = []
    for axis, col in columns.items():
        warm = summarize_cycles([np.nan if (t := c.warmup_time_s(axis)) is None else t
                                 for c in cycles], confidence, positive=True)
        points = temperature_points(views, col, spec)
        linear, quadratic = _fits(points, spec, confidence)
        biases = _turn_on_biases(cycles, axis, linear)
        if linear is not None and len(linear.switch_ons) > 1:
            fit_notes.append(_switch_on_fit_note(axis, linear, biases is not None))
        if biases is None:
            biases = [b for c in cycles if (b := c.biases.get(axis)) is not None]
        hyst = None if linear is None else hysteresis(
            points, tolerance_c=spec.plateau_span_c, slope_deg_h_per_c=linear.slope_deg_h_per_c)
        if hyst is not None and linear is not None and linear.chi2_reduced is not None:
            # the points scatter about the fit more than their own errors say (the bias
            # wanders between plateaus): the difference's error grows by as much
            birge = math.sqrt(max(1.0, linear.chi2_reduced))
            hyst = dataclasses.replace(hyst, stderr_deg_h=hyst.stderr_deg_h * birge)
        axes.append(AxisSequence(axis, turn_on_repeatability(biases, confidence), warm,
                                 tuple(points), linear, quadratic, hyst))
    turn_on = summarize_cycles([np.nan if c.turn_on_time_s is None else c.turn_on_time_s
                                for c in cycles], confidence, positive=True)
    figures = _canonical(axes, turn_on, confidence)
    graded = tuple(_graded(s, figures[_FIGURE_OF[s.name]], profile) for s in spec.figures)
    limited = [g for g in graded if g.spec.limits]
    grade = deciding = ""
    if limited:
        grade, deciding, _ = assign_grade(limited, profile.grades, profile.reject)
    notes = [*_notes(cycles, spec, axes, len(views)), *fit_notes]
    if not views:
        notes.append(f"{unit_id}: no segment holds this unit")
        if limited:
            grade = INDETERMINATE
    plateaus = plateau_analyses(views, run.steps, columns, spec, profile)
    return UnitSequence(unit_id, run.name, tuple(cycles), turn_on, tuple(axes), figures,
                        graded, grade, deciding, confidence, tuple(notes), plateaus)
