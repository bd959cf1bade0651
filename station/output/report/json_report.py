"""The spec sheet as JSON for a factory MES; the schema is docs/report-json-schema.md.

The document is :meth:`station.evaluation.grading.RunGrade.as_json` (schema
``gyro-station/spec-sheet``)
with, per unit, the header, the event summary, and per axis the Allan curve and the fit.
"""

from __future__ import annotations

import json
from pathlib import Path

from analysis.units.conversions import S_PER_H
from station.evaluation.accel_axes import accel_fit_dict
from station.evaluation.grading import RunGrade
from station.output.json_units import in_family
from station.output.report.common import event_summary, header_fields

SCHEMA = "gyro-station/spec-sheet"
SCHEMA_VERSION = 1


def spec_sheet_json(graded: RunGrade) -> dict[str, object]:
    """The JSON document of a graded run's spec sheets."""
    doc = graded.as_json()
    doc["schema"], doc["schema_version"] = SCHEMA, SCHEMA_VERSION
    units = doc["units"]
    assert isinstance(units, list)
    for unit_doc, unit in zip(units, graded.units, strict=True):
        unit_doc["header"] = dict(header_fields(graded, unit))
        unit_doc["events"] = event_summary(unit.unit, graded).as_json()
        for axis in unit.axes:
            al = axis.analysis.allan
            # an accelerometer axis: its curve in m/s^2 and its fit in accelerometer units
            accel = axis.analysis.accel is not None
            scale, unit_key = (1.0, "m_s2") if accel else (S_PER_H, "deg_h")
            unit_doc["axes"][axis.axis]["allan"] = {
                "estimator": al.estimator, "confidence": al.confidence, "tau_s": al.tau_s.tolist(),
                f"adev_{unit_key}": (al.adev * scale).tolist(),
                f"adev_ci_low_{unit_key}": (al.adev_ci_low * scale).tolist(),
                f"adev_ci_high_{unit_key}": (al.adev_ci_high * scale).tolist()}
            fit = axis.analysis.fit.as_dict()
            unit_doc["axes"][axis.axis]["fit"] = accel_fit_dict(fit) if accel else fit
            if axis.analysis.gmwm is not None:  # `station report --method gmwm`
                unit_doc["axes"][axis.axis]["gmwm"] = axis.analysis.gmwm.as_json()
    return doc


def write_json(graded: RunGrade, path: str | Path) -> Path:
    """Write the JSON spec sheet document in ``graded.output_units`` (NaN/inf are not allowed: they
    become errors)."""
    path = Path(path)
    doc = in_family(spec_sheet_json(graded), graded.output_units)
    path.write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    return path
