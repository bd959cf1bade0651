"""The producer's statistics of the results database, per model (profile) and lot.

Over the latest grading of each unit (filtered by model, lot and test date), model by model
(:func:`compute_stats_by_model`: the models' units are never pooled, each model has its own
profile, limits and test order): the yield per
grade; per graded figure its distribution against the profile's limits, its mean and
standard deviation, Cp and Cpk against the acceptance limit (the loosest grade's, which
divides the units sold from those rejected), and an individuals control chart in test
order (:mod:`station.evaluation.capability`); and the units flagged for a person's
review: those whose grading says so, and those with a figure out of statistical control.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

from station.errors import ProfileError
from station.evaluation.capability import (
    Capability,
    ControlChart,
    capability,
    finite_or_none,
    individuals_chart,
)
from station.model.profiles import parse_profile
from station.output.results import FigureValue, GradingRow, ResultsDatabase


@dataclass(frozen=True)
class FigureStats:
    """One graded figure over the units: values in test order, limits, capability, chart."""

    name: str
    unit: str
    #: The profile's limits, grade by grade (best grade first), in ``unit``.
    limits: dict[str, float]
    values: tuple[FigureValue, ...]
    capability: Capability
    chart: ControlChart

    @property
    def out_of_control(self) -> tuple[FigureValue, ...]:
        """The values beyond the control limits."""
        return tuple(self.values[i] for i in self.chart.out_of_control)

    def as_json(self) -> dict[str, object]:
        """``{"mean", "std", "cp", "cpk", "cpu", "cpk_ci", "cpk_fitted", "limits", ...}``
        (``limits``: the grades' upper limits, best grade first; ``limit``: the acceptance
        limit the indexes use; ``cp`` is null: no lower limit; docs/json.md)."""
        c, k, f = self.capability, self.chart, self.capability.fitted
        return {
            "mean": c.mean,
            "std": c.std,
            "cp": finite_or_none(c.cp),
            "cpk": finite_or_none(c.cpk),
            "cpu": finite_or_none(c.cpu),
            "cpk_ci": list(c.cpk_ci) if c.cpk_ci is not None else None,
            "cpk_fitted": finite_or_none(f.cpk) if f is not None else None,
            "cpk_fitted_ci": list(f.cpk_ci) if f is not None and f.cpk_ci is not None else None,
            "fitted_distribution": f.distribution if f is not None else None,
            "fitted_median": f.median if f is not None else None,
            "fitted_p99865": f.p99865 if f is not None else None,
            "limits": list(self.limits.values()),
            "limit_grades": list(self.limits),
            "limit": c.limit,
            "unit": self.unit,
            "n": c.n,
            "above_limit": c.above_limit,
            "center": k.center,
            "ucl": k.ucl,
            "lcl": k.lcl,
            "out_of_control": [
                {
                    "serial_number": v.serial_number,
                    "axis": v.axis,
                    "test_date": v.test_date,
                    "value": v.value,
                }
                for v in self.out_of_control
            ],
        }


@dataclass(frozen=True)
class ReviewUnit:
    """A unit a person should look at, and why."""

    serial_number: str
    model: str
    lot: str
    grading_id: int
    test_date: str
    reasons: tuple[str, ...]

    def as_json(self) -> dict[str, object]:
        """The unit and its reasons."""
        return {
            "serial_number": self.serial_number,
            "model": self.model,
            "lot": self.lot,
            "grading_id": self.grading_id,
            "test_date": self.test_date,
            "reasons": list(self.reasons),
        }


@dataclass(frozen=True)
class ProductionStats:
    """The statistics of the units a model, lot and first test date select (None: all)."""

    model: str | None = None
    lot: str | None = None
    since: str | None = None
    units: int = 0
    grades: dict[str, int] = field(default_factory=dict)
    figures: dict[str, FigureStats] = field(default_factory=dict)
    review: tuple[ReviewUnit, ...] = ()
    profile: str = ""
    #: Per lot ("" for units of no lot), the units per grade (the order of ``grades``).
    lots: dict[str, dict[str, int]] = field(default_factory=dict)
    #: The profile's grades that are sold (best first; empty when its text was not stored).
    sold: tuple[str, ...] = ()

    def lot_yield(self, lot: str) -> float | None:
        """Share of the lot's units (0..1) in a sold grade (None: the grades are not known)."""
        counts = self.lots.get(lot, {})
        n = sum(counts.values())
        if not self.sold or not n:
            return None
        return sum(counts.get(g, 0) for g in self.sold) / n

    @property
    def yield_by_grade(self) -> dict[str, float]:
        """Share of the units (0..1) per grade."""
        return {g: n / self.units for g, n in self.grades.items()} if self.units else {}

    def as_json(self) -> dict[str, object]:
        """``{"units", "yield": {grade: share}, "figures": {name: {...}}, ...}``."""
        return {
            "units": self.units,
            "yield": self.yield_by_grade,
            "figures": {name: f.as_json() for name, f in self.figures.items()},
            "grades": dict(self.grades),
            "review": [u.as_json() for u in self.review],
            "model": self.model,
            "lot": self.lot,
            "since": self.since,
            "profile": self.profile,
            "lots": {lot: dict(counts) for lot, counts in self.lots.items()},
            "lot_yield": {lot: self.lot_yield(lot) for lot in self.lots},
        }


def _limits(
    db: ResultsDatabase, rows: list[GradingRow]
) -> tuple[str, dict[str, dict[str, float]], tuple[str, ...], tuple[str, ...]]:
    """(profile, limits per figure, grades best first, the sold grades) of the newest
    grading's profile."""
    if not rows:
        return "", {}, (), ()
    ref, text = db.profile_text(rows[-1].id)
    if not text:
        return ref, {}, (), ()
    try:
        profile = parse_profile(text, path=ref)
    except ProfileError:
        return ref, {}, (), ()
    figures = [(f.name, f.limits) for f in profile.figures if f.graded]
    # a test sequence's figures (a name in two sequences: the first sequence's limits)
    figures += [(f.name, f.limits) for seq in reversed(profile.sequences.values())
                for f in seq.figures if f.limits]
    return (
        ref,
        {name: {g: limits[g] for g in profile.grades if g in limits} for name, limits in figures},
        (*profile.grades, "indeterminate", profile.reject),
        profile.grades,
    )


@dataclass(frozen=True)
class StatsByModel:
    """The statistics of each model among the selected units, one block per model (sorted
    by name), never pooled: every model has its own profile, limits, control charts and run
    rules. ``model`` set: the selection names that model, and its block is the only one."""

    models: dict[str, ProductionStats] = field(default_factory=dict)
    model: str | None = None
    lot: str | None = None
    since: str | None = None

    @property
    def units(self) -> int:
        """Units over every model (the latest grading of each)."""
        return sum(s.units for s in self.models.values())

    def as_json(self) -> dict[str, object]:
        """With ``model``: that model's document (:meth:`ProductionStats.as_json`); without:
        ``{"units", "model": null, "lot", "since", "models": {model: its document}}``."""
        if self.model is not None:
            return self.models[self.model].as_json()
        return {"units": self.units, "model": None, "lot": self.lot, "since": self.since,
                "models": {m: s.as_json() for m, s in self.models.items()}}


def compute_stats_by_model(
    db: ResultsDatabase,
    *,
    model: str | None = None,
    lot: str | None = None,
    since: str | None = None,
) -> StatsByModel:
    """The statistics of the latest grading of each unit that ``model``, ``lot`` and
    ``since`` (ISO 8601 test date) select, one :class:`ProductionStats` per model (with
    ``model``: that model's alone, present with 0 units when none is selected)."""
    rows = db.gradings(model=model, lot=lot, since=since, latest=True)
    values = db.figure_values(model=model, lot=lot, since=since)
    model_of = {r.id: r.model for r in rows}
    names = [model] if model is not None else sorted(set(model_of.values()))
    return StatsByModel(
        {m: _model_stats(db, [r for r in rows if r.model == m],
                         [v for v in values if model_of.get(v.grading_id) == m],
                         model=m, lot=lot, since=since)
         for m in names},
        model, lot, since,
    )


def compute_stats(
    db: ResultsDatabase,
    *,
    model: str | None = None,
    lot: str | None = None,
    since: str | None = None,
) -> ProductionStats:
    """The statistics of the latest grading of each unit that ``model``, ``lot`` and
    ``since`` (ISO 8601 test date) select, as one block: give ``model`` (without it, the
    units of every model are pooled under the newest grading's profile;
    :func:`compute_stats_by_model` keeps the models apart)."""
    rows = db.gradings(model=model, lot=lot, since=since, latest=True)
    values = db.figure_values(model=model, lot=lot, since=since)
    return _model_stats(db, rows, values, model=model, lot=lot, since=since)


def _model_stats(
    db: ResultsDatabase,
    rows: list[GradingRow],
    values: list[FigureValue],
    *,
    model: str | None,
    lot: str | None,
    since: str | None,
) -> ProductionStats:
    """The statistics of the gradings ``rows`` and their graded figures ``values``."""
    profile, limits, order, sold = _limits(db, rows)
    counts = Counter(r.grade for r in rows)
    grades = {g: counts[g] for g in order if counts[g]} | {
        g: n for g, n in counts.items() if g not in order
    }
    lots: dict[str, dict[str, int]] = {}
    for name in sorted({r.lot for r in rows}):
        in_lot = Counter(r.grade for r in rows if r.lot == name)
        lots[name] = {g: in_lot[g] for g in grades if in_lot[g]}
    by_name: dict[str, list[FigureValue]] = {}
    for v in values:
        by_name.setdefault(v.name, []).append(v)
    figures = {}
    for name, vs in by_name.items():
        figure_limits = limits.get(name, {})
        if not figure_limits:  # the profile's text was not stored: the limits the units met
            seen = [v.limit for v in vs if v.limit is not None]
            figure_limits = {"stored": max(seen)} if seen else {}
        acceptance = max(figure_limits.values()) if figure_limits else None
        x = [float("nan") if v.value is None else v.value for v in vs]
        figures[name] = FigureStats(
            name,
            vs[0].unit,
            figure_limits,
            tuple(vs),
            capability(x, acceptance),
            individuals_chart(x),
        )
    return ProductionStats(
        model, lot, since, len(rows), grades, figures, _review(rows, figures), profile, lots,
        sold,
    )


def _review(rows: list[GradingRow], figures: dict[str, FigureStats]) -> tuple[ReviewUnit, ...]:
    reasons: dict[int, list[str]] = {r.id: list(r.review.splitlines()) for r in rows}
    for f in figures.values():
        k = f.chart
        for v in f.out_of_control:
            side = (
                "above the upper"
                if k.ucl is not None and (v.value or 0) > k.ucl
                else "below the lower"
            )
            bound = k.ucl if "upper" in side else k.lcl
            reasons[v.grading_id].append(
                f"{f.name} {v.axis or 'unit'} = {v.value:.4g} {f.unit} is out of control "
                f"({side} control limit {bound:.4g})"
            )
    return tuple(
        ReviewUnit(r.serial_number, r.model, r.lot, r.id, r.test_date, tuple(reasons[r.id]))
        for r in rows
        if reasons[r.id]
    )
