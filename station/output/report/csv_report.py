"""The spec sheet as CSV: one row per unit and axis, five columns per figure.

Columns: run, unit_id, model, serial_number, lot, test_date, profile, rule, confidence,
unit_grade, axis, axis_grade, deciding_grade, then for every figure of the profile
``<figure>_unit``, ``<figure>_value``, ``<figure>_ci_low``, ``<figure>_ci_high``,
``<figure>_limit`` (of the deciding grade, empty for informational figures) and
``<figure>_verdict`` (``pass``, ``fail``, ``indeterminate``, or ``info``); last, what the
analysis did to the record: ``spikes`` (found), ``spikes_removed`` (true/false), ``gaps``,
``missing_s`` and ``earth_rate_removed_deg_h`` (empty when not removed), ``tones`` (each
``<freq_hz> Hz <amplitude_deg_s> deg/s``, ``;``-separated; in the rad family
``earth_rate_removed_rad_s`` and rad/s) and ``review`` (the axis' review
reasons, ``;``-separated; empty when read-off and fit agree).
"""

from __future__ import annotations

import csv
from pathlib import Path

from station.evaluation.grading import RunGrade
from station.output.report.common import figure_rows

FIXED = [
    "run",
    "unit_id",
    "model",
    "serial_number",
    "lot",
    "test_date",
    "profile",
    "rule",
    "confidence",
    "unit_grade",
    "axis",
    "axis_grade",
    "deciding_grade",
]
PER_FIGURE = ["unit", "value", "ci_low", "ci_high", "limit", "verdict"]
ANALYSIS = [
    "spikes",
    "spikes_removed",
    "gaps",
    "missing_s",
    "earth_rate_removed_deg_h",
    "tones",
    "review",
]


def _cell(value: object) -> object:
    return "" if value is None else value


def write_csv(graded: RunGrade, path: str | Path) -> Path:
    """Write one row per unit and axis (numbers in full precision, each figure in its unit)."""
    path = Path(path)
    p, run = graded.profile, graded.run
    names = [f.name for f in p.figures]
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        family = graded.output_units
        rate = family.label("deg/h")
        analysis = [c.replace("_deg_h", "_rad_s") if rate == "rad/s" else c for c in ANALYSIS]
        writer.writerow(FIXED + [f"{n}_{c}" for n in names for c in PER_FIGURE] + analysis)
        for unit in graded.units:
            u = unit.unit
            for axis in unit.axes:
                rows = {r.name: r for r in figure_rows(axis, family)}
                fixed = [
                    run.path,
                    u.unit_id,
                    u.model or p.model,
                    u.serial_number,
                    run.metadata.lot,
                    run.start_utc or graded.graded_utc,
                    p.ref,
                    p.rule,
                    p.confidence,
                    unit.grade,
                    axis.axis,
                    axis.grade,
                    axis.deciding_grade,
                ]
                cells: list[object] = []
                for n in names:
                    if n not in rows:  # a rate figure on an accelerometer axis, or the reverse
                        cells += [""] * len(PER_FIGURE)
                        continue
                    r = rows[n]
                    cells += [
                        r.unit,
                        _cell(r.value),
                        _cell(r.ci_low),
                        _cell(r.ci_high),
                        _cell(r.limit),
                        r.verdict or "info",
                    ]
                an = axis.analysis
                cells += [
                    an.outliers.count,
                    str(an.outliers.removed).lower(),
                    an.gaps.count,
                    an.gaps.missing_s,
                    _cell(family.value(an.figures.earth_rate_removed_deg_h, "deg/h")),
                    "; ".join(
                        f"{t.freq_hz:.6g} Hz {family.value(t.amplitude_deg_s, 'deg/s'):.4g} "
                        f"{family.label('deg/s')}"
                        for t in an.tones
                    ),
                    "; ".join(axis.review),
                ]
                writer.writerow(fixed + cells)
    return path
