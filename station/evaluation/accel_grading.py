"""Grading accelerometer axes: each ``accel_*`` figure of a profile is the rate figure of
the same name computed on the axis' m/s^2 series (the gyro's read-offs, fits and
intervals), scaled from the rate figure's canonical unit to the accelerometer's (ug,
m/s/sqrt(h), m/s/h^1.5); the bias is taken with the gravity projection removed
(:mod:`station.evaluation.accel_axes`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from analysis.figures.accel import STANDARD_GRAVITY_M_S2
from analysis.units.conversions import S_PER_H
from station.evaluation.analyze import AxisAnalysis
from station.evaluation.decision import GradingError, match_axes
from station.evaluation.figure_intervals import Interval, bias_interval, figure_interval
from station.model.profiles import FigureSpec, Profile, is_accel_figure
from station.model.records import RateRecord

#: The rate figure each accelerometer figure is computed as.
RATE_FIGURE = {
    "accel_bias": "bias",
    "accel_vrw": "arw",
    "accel_bias_instability": "bias_instability",
    "accel_adev_min": "adev_min",
    "accel_vrw_fit": "arw_fit",
    "accel_bias_instability_fit": "bias_instability_fit",
    "accel_random_walk": "rrw",
}
#: From the rate figure's canonical unit, on an m/s^2 series, to the accelerometer
#: figure's canonical unit, per dimension ("deg/h" of m/s^2 is m/s^2 x 3600 -> ug).
_FACTOR = {"accel": 1e6 / STANDARD_GRAVITY_M_S2 / S_PER_H, "vrw": 1.0, "accel_rw": 1.0}


def accel_columns(profile: Profile, record: RateRecord) -> dict[str, int]:
    """Column of each profile axis among ``record``'s accelerometers; {} when the profile
    grades no accelerometer figure.

    Raises
    ------
    GradingError
        The profile limits an accelerometer figure and the record has no accelerometer.
    """
    graded = [f.name for f in profile.figures if is_accel_figure(f.name) and f.graded]
    if not graded:
        return {}
    if record.accel_m_s2 is None or not record.accel_axis_names:
        raise GradingError(
            f"profile {profile.name} limits accelerometer figure(s) {', '.join(graded)} but "
            f"{record.source or 'the record'} has no accelerometer (accel_* columns)")
    return match_axes(profile.axes, record.accel_axis_names)


def accel_only_notes(profile: Profile, record: RateRecord, accel: dict[str, int]) -> list[str]:
    """The unit notes of a record with accelerometer axes only (none for one with a gyro
    axis): which rate figures of the profile go ungraded.

    Raises
    ------
    GradingError
        The record has no gyro axis and the profile grades no accelerometer figure.
    """
    if record.axis_names:
        return []
    if not accel:
        raise GradingError(
            f"{record.source or 'the record'} has accelerometer axes only and profile "
            f"{profile.name} grades no accelerometer figure (accel_*)")
    rate = [f.name for f in profile.figures if not is_accel_figure(f.name) and f.graded]
    return ([f"accelerometer-only record: the profile's rate figure(s) {', '.join(rate)} are "
             f"not measured and not graded; the grade is the accelerometers'"] if rate else [])


def figures_for(profile: Profile, analysis: AxisAnalysis) -> tuple[FigureSpec, ...]:
    """The profile figures graded on this axis: accelerometer figures on an accelerometer
    axis, the others on a rate axis."""
    accel = analysis.accel is not None
    return tuple(f for f in profile.figures if is_accel_figure(f.name) == accel)


def accel_figure_interval(name: str, x: np.ndarray, analysis: AxisAnalysis, confidence: float,
                          *, source: str) -> Interval:
    """An accelerometer figure (canonical unit) with its interval from one accelerometer
    axis' series (m/s^2) and analysis."""
    rate_name = RATE_FIGURE[name]
    dimension = {"arw": "vrw", "arw_fit": "vrw", "rrw": "accel_rw"}.get(rate_name, "accel")
    if rate_name == "bias":
        g = analysis.accel.gravity_removed_m_s2 if analysis.accel is not None else None
        b = bias_interval(x - (g or 0.0), confidence)
        said = ("gravity not removed" if not g else f"gravity {g:+.6g} m/s^2 removed")
        interval = replace(b, note="; ".join(t for t in (b.note, said) if t))
    else:
        interval = figure_interval(rate_name, x, analysis, confidence, source=source)
    f = _FACTOR[dimension]

    def scaled(v: float | None) -> float | None:
        return None if v is None else v * f

    return replace(interval, value=scaled(interval.value), low=scaled(interval.low),
                   high=scaled(interval.high))
