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
reasons, ``;``-separated; empty when read-off and fit agree). Where the run was analysed
with the GMWM (``station report --method gmwm``, or the profile's ``[test] gmwm_model``),
``gmwm_model`` and ``gmwm_p_value`` (its J test) follow, then for each GMWM parameter of
any axis ``gmwm_<key>``, ``gmwm_<key>_unit``, ``gmwm_<key>_ci_low`` and
``gmwm_<key>_ci_high`` (``gmwm_wn_deg_rt_h``, ``gmwm_gm_tau_s``...; empty where an axis'
model has no such term).
"""

from __future__ import annotations

import csv
from pathlib import Path

from station.evaluation.grading import RunGrade
from station.output.report.common import figure_rows
from station.output.report.gmwm_terms import (
    GmwmRow,
    gmwm_model_name,
    gmwm_p_value,
    gmwm_rows,
    has_gmwm,
)

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


GMWM_PER_KEY = ["", "_unit", "_ci_low", "_ci_high"]


def gmwm_keys(graded: RunGrade) -> list[str]:
    """The GMWM parameters of every axis of ``graded``, in the order they first appear
    (empty when no axis carries a GMWM)."""
    keys: dict[str, None] = {}
    for unit in graded.units:
        for axis in unit.axes:
            keys.update((r.key, None) for r in gmwm_rows(axis))
    return list(keys)


def _gmwm_cells(row: GmwmRow | None) -> list[object]:
    if row is None:
        return [""] * len(GMWM_PER_KEY)
    return [_cell(row.value), row.unit, _cell(row.ci_low), _cell(row.ci_high)]


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
        keys = gmwm_keys(graded) if any(has_gmwm(u) for u in graded.units) else []
        gmwm = (["gmwm_model", "gmwm_p_value"]
                + [f"gmwm_{k}{c}" for k in keys for c in GMWM_PER_KEY]) if keys else []
        writer.writerow(FIXED + [f"{n}_{c}" for n in names for c in PER_FIGURE] + analysis
                        + gmwm)
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
                if keys:
                    terms = {r.key: r for r in gmwm_rows(axis)}
                    cells += [gmwm_model_name(axis), _cell(gmwm_p_value(axis))]
                    for k in keys:
                        cells += _gmwm_cells(terms.get(k))
                writer.writerow(fixed + cells)
    return path
