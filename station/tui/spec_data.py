"""What the spec-sheet screen's Allan tab draws, from a graded unit (no widgets here).

The same quantities as the report panels (:mod:`station.output.report.panels`), as
:class:`~station.tui.live.Series` for a terminal plot: the measured Allan deviation of
each axis with its fitted model and the fitted terms as their slope lines, and the
deciding grade's limit lines (:func:`station.evaluation.limits.limit_lines`). The DAVAR
tab draws :func:`station.evaluation.davar_map.davar_grid` (:mod:`station.tui.heatmap`).
"""

from __future__ import annotations

import numpy as np

from analysis.fit.least_squares import TERMS
from analysis.units.conversions import S_PER_H
from station.evaluation.grading import AxisGrade
from station.evaluation.limits import limit_lines
from station.tui.live import Series


def allan_series(axes: tuple[AxisGrade, ...]) -> tuple[Series, ...]:
    """Measured ADEV (points), fit (line), fitted terms of the first axis (dashed) and the
    first axis's limit lines, all in deg/h (an accelerometer axis: m/s^2, no limit lines)
    against tau in s (:func:`adev_unit`); the terms and limits are kept within a decade of
    the measured values."""
    out: list[Series] = []
    for a in axes:
        al, fit = a.analysis.allan, a.analysis.fit
        scale = _scale(a)
        out.append(Series(f"{a.axis} measured", al.tau_s, al.adev * scale, "points"))
        out.append(
            Series(f"{a.axis} fitted", al.tau_s, np.sqrt(fit.model_avar(al.tau_s)) * scale)
        )
    if axes:
        first = axes[0]
        tau, fit = first.analysis.allan.tau_s, first.analysis.fit
        measured = first.analysis.allan.adev * _scale(first)
        for term in TERMS:
            curve = np.sqrt(fit.term_avar(term, tau)) * _scale(first)
            if np.any(curve > 0):
                out.append(Series(term, tau, curve, "dashed"))
        out += limit_series(first) if first.analysis.accel is None else []
        out = [clip_to(s, measured) for s in out]
    return tuple(out)


def _scale(axis: AxisGrade) -> float:
    """deg/s -> deg/h for a rate axis; 1 for an accelerometer axis (m/s^2)."""
    return 1.0 if axis.analysis.accel is not None else S_PER_H


def adev_unit(axis: AxisGrade) -> str:
    """The unit :func:`allan_series` draws ``axis`` in."""
    return "m/s^2" if axis.analysis.accel is not None else "deg/h"


def clip_to(series: Series, measured: np.ndarray, decades: float = 1.0) -> Series:
    """``series`` without the points more than ``decades`` outside the measured range (a
    fitted term far below or above the data would squash the plot); data are kept."""
    if series.kind != "dashed" or not len(measured):
        return series
    finite = measured[np.isfinite(measured) & (measured > 0)]
    if not len(finite):
        return series
    low, high = finite.min() / 10**decades, finite.max() * 10**decades
    keep = (series.y >= low) & (series.y <= high)
    return Series(series.label, series.x[keep], series.y[keep], series.kind)


def limit_series(axis: AxisGrade) -> list[Series]:
    """The deciding grade's limit lines (deg/h), as the PDF draws them."""
    return [Series(f"limit {line.figure}", line.tau_s, line.adev_deg_h, "dashed")
            for line in limit_lines(axis)]
