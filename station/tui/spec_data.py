"""What the spec-sheet screen draws, computed from a graded unit (no widgets here).

The same quantities as the report panels (:mod:`station.report.panels`), as
:class:`~station.tui.live.Series` for a terminal plot: the measured Allan deviation of
each axis with its fitted model and the fitted terms as their slope lines, the deciding
grade's limit lines, and the DAVAR as one Allan curve per time window.
"""

from __future__ import annotations

import math

import numpy as np

from analysis.errors import AnalysisError
from analysis.fit import TERMS
from analysis.units import S_PER_H
from station.grading import AxisGrade, UnitGrade, run_profile_ref
from station.profiles import available_profiles, load_profile
from station.runs import RunInfo
from station.tui.live import Series

#: DAVAR windows drawn (first, last and evenly between) and the windows across the record.
DAVAR_CURVES = 4
DAVAR_WINDOWS = 8


def allan_series(axes: tuple[AxisGrade, ...]) -> tuple[Series, ...]:
    """Measured ADEV (points), fit (line), fitted terms of the first axis (dashed) and the
    first axis's limit lines, all in deg/h against tau in s; the terms and limits are kept
    within a decade of the measured values."""
    out: list[Series] = []
    for a in axes:
        al, fit = a.analysis.allan, a.analysis.fit
        out.append(Series(f"{a.axis} measured", al.tau_s, al.adev * S_PER_H, "points"))
        out.append(Series(f"{a.axis} fitted", al.tau_s, np.sqrt(fit.model_avar(al.tau_s)) * S_PER_H))
    if axes:
        first = axes[0]
        tau, fit = first.analysis.allan.tau_s, first.analysis.fit
        measured = first.analysis.allan.adev * S_PER_H
        for term in TERMS:
            curve = np.sqrt(fit.term_avar(term, tau)) * S_PER_H
            if np.any(curve > 0):
                out.append(Series(term, tau, curve, "dashed"))
        out += limit_series(first)
        out = [clip_to(s, measured) for s in out]
    return tuple(out)


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
    """The deciding grade's ARW limit as a -1/2 line and the bias-instability limit as a
    level (deg/h), as the PDF draws them."""
    tau = axis.analysis.allan.tau_s
    out = []
    for f in axis.figures:
        limit = f.spec.limits.get(axis.deciding_grade)
        if limit is None:
            continue
        canonical = limit * f.spec.unit_factor
        label = f"limit {f.name}"
        if f.name in ("arw", "arw_fit"):  # deg/sqrt(h) -> deg/h at tau
            out.append(Series(label, tau, canonical * math.sqrt(S_PER_H) / np.sqrt(tau), "dashed"))
        elif f.name in ("bias_instability", "bias_instability_fit", "adev_min"):
            level = canonical * (0.664 if f.name != "adev_min" else 1.0)
            out.append(Series(label, tau, np.full(len(tau), level), "dashed"))
    return out


def davar_series(unit: UnitGrade, axis_index: int = 0) -> tuple[Series, ...]:
    """Allan deviation (deg/h) against tau (s) in :data:`DAVAR_CURVES` windows of the whole
    record (warm-up included: it is what the DAVAR shows); empty if the record is too short.
    """
    from analysis.davar import dynamic_allan_variance

    record = unit.unit.record
    axis = unit.axes[axis_index]
    column = record.axis_names.index(axis.axis) if axis.axis in record.axis_names else axis_index
    window_s = record.duration_s / DAVAR_WINDOWS
    try:
        result = dynamic_allan_variance(record.rate_deg_s[:, column], record.sample_rate_hz,
                                        window_s=window_s, step_s=window_s / 4, backend="numpy")
    except AnalysisError:
        return ()
    n = len(result.t_s)
    picks = sorted({round(i * (n - 1) / max(1, DAVAR_CURVES - 1)) for i in range(DAVAR_CURVES)})
    return tuple(Series(f"t={result.t_s[i] / 60:.0f} min", result.tau_s,
                        np.sqrt(result.avar[i]) * S_PER_H) for i in picks)


def guess_profile(run: RunInfo) -> str | None:
    """The run's profile, else the first profile whose model is a unit's model."""
    if run.profile:
        return run_profile_ref(run)
    models = {u.model for u in run.units}
    for name in available_profiles():
        try:
            if load_profile(name).model in models:
                return name
        except (OSError, ValueError):
            continue
    return None
