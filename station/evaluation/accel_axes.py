"""Accelerometer axes of an IMU record: analysed by the gyro's code paths in m/s^2, then
read as accelerometer figures (:mod:`analysis.figures.accel`), with gravity taken off the bias.

The gravity on each axis comes from the bench (latitude and height: the WGS-84 normal
gravity; the axis' direction: its up component) when the bench gives both; otherwise
the axis whose mean is nearest 1 g is taken as the vertical, at standard gravity, and the
note says so (docs/bench.md).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from analysis.figures.accel import (
    STANDARD_GRAVITY_M_S2,
    accel_figures,
    gravity_by_axis,
    normal_gravity_m_s2,
    vertical_axis,
)
from analysis.fit.result import NoiseCoefficients
from analysis.units.conversions import S_PER_H
from station.evaluation.axis_analysis import (
    ACCEL_FIT_KEYS as ACCEL_FIT_KEYS,
    AxisAnalysis,
    Quantity as Quantity,
    accel_curve_keys as accel_curve_keys,
    accel_fit_dict as accel_fit_dict,
    accel_unit as accel_unit,
)
from station.model.bench import Bench
from station.model.records import RateRecord


def accel_record(record: RateRecord) -> RateRecord | None:
    """The accelerometer axes of ``record`` as a record the rate analysis takes (values in
    m/s^2 where it expects deg/s); None when the record has none."""
    if record.accel_m_s2 is None or not record.accel_axis_names:
        return None
    return RateRecord(record.accel_m_s2, record.sample_rate_hz, record.accel_axis_names,
                      record.source, record.temperature_c, record.sample_index)


def gravity_on_axes(bench: Bench | None, names: Sequence[str], means_m_s2: Sequence[float]
                    ) -> tuple[list[float | None], list[str]]:
    """(gravity on each axis in m/s^2, a note per axis): from the bench when it gives the
    latitude and the axis' direction, else the axis nearest +-1 g at standard gravity."""
    if bench is not None and bench.latitude_deg is not None and bench.axes:
        g = normal_gravity_m_s2(bench.latitude_deg, bench.height_m or 0.0)
        on_axes = gravity_by_axis(g, bench.axes, names)
        if any(v is not None for v in on_axes):
            where = (f"latitude {bench.latitude_deg:g} deg, height {bench.height_m or 0.0:g} m"
                     + ("" if bench.height_m is not None else " (no height_m on the bench)"))
            notes = [f"gravity {v:+.6g} m/s^2 removed from the bias (WGS-84 normal gravity "
                     f"{g:.6g} m/s^2 at {where}; axis {bench.direction_text(n)})"
                     if v is not None else
                     f"gravity not removed from the bias: the bench gives no direction for "
                     f"axis {n!r}" for n, v in zip(names, on_axes, strict=True)]
            return on_axes, notes
    up = vertical_axis(means_m_s2)
    sign = 1.0 if means_m_s2[up] >= 0 else -1.0
    out: list[float | None] = [0.0] * len(names)
    out[up] = sign * STANDARD_GRAVITY_M_S2
    why = "no bench orientation and latitude (--bench FILE)"
    notes = [f"gravity {v:+.6g} m/s^2 (standard gravity) removed from the bias: {names[up]!r} "
             f"is nearest {sign:+.0f} g and taken as the vertical, {why}" if i == up else
             f"no gravity removed from the bias: {names[up]!r} is taken as the vertical, {why}"
             for i, v in enumerate(out)]
    return out, notes


def analyze_accel(record: RateRecord, bench: Bench | None,
                  analyse: Callable[[RateRecord], list[AxisAnalysis]]) -> list[AxisAnalysis]:
    """The accelerometer axes of ``record`` through ``analyse`` (the rate analysis, Earth
    rate off), each with its :class:`analysis.figures.accel.AccelFigures` and quantity set."""
    accel = accel_record(record)
    if accel is None:
        return []
    axes = analyse(accel)
    means = [float(np.nanmean(a.rate_deg_s)) if a.rate_deg_s is not None
             else a.figures.bias_deg_h / S_PER_H for a in axes]
    gravity, notes = gravity_on_axes(bench, accel.axis_names, means)
    out = []
    for a, g, note in zip(axes, gravity, notes, strict=True):
        kept = tuple(n for n in a.figures.notes if not n.startswith("Earth rate"))
        figures = accel_figures(a.figures, a.fit, gravity_removed_m_s2=g,
                                notes=(note, *kept))
        out.append(replace(a, quantity="acceleration", accel=figures))
    return out


def _cell(value: float | None, digits: int = 4) -> str:
    return "-" if value is None else f"{value:.{digits}g}"


def _interval_cell(ci: tuple[float | None, float | None] | None) -> str:
    if ci is None or ci[0] is None or ci[1] is None:
        return "-"
    return f"[{ci[0]:.4g}, {ci[1]:.4g}]"


def _fit_cell(fit: NoiseCoefficients, term: str) -> str:
    """A fitted term in the accelerometer unit, +- its standard error; a term fitted to 0
    is the record's bound on it: ``<= stderr``."""
    if term in fit.negative_terms:
        return "negative"
    factor = ACCEL_FIT_KEYS[term][1]
    value, err = fit.values[term], fit.stderr[term]
    if value is None:
        return "-"
    if value == 0 and err is not None and err > 0:
        return f"0 (<= {err * factor:.2g})"
    return f"{value * factor:.4g}" + ("" if err is None else f" +- {err * factor:.2g}")


#: The fitted terms of the accelerometer table: (term, label with its unit).
_FIT_ROWS = (("Q", "fit Q quantization [m/s]"), ("N", "fit N VRW [m/s/sqrt(h)]"),
             ("B", "fit B bias instability [ug]"), ("K", "fit K accel. random walk [m/s/h^1.5]"),
             ("R", "fit R accel. ramp [m/s/h^2]"))


def format_accel_table(axes: Sequence[AxisAnalysis]) -> str:
    """A plain-text table of the accelerometer figures of ``axes`` (SI, bias in mg,
    bias instability in ug), each read-off with its interval and the taus it was read at,
    each fitted term +- its standard error (``<=`` its bound where fitted to 0), a VRW that
    only bounds the white noise marked ``<=``; then each axis' tones (amplitudes in m/s^2)
    and notes."""
    figs = [a.accel for a in axes if a.accel is not None]
    confidence = axes[0].allan.confidence if axes else 0.0
    rows = [
        ("samples", [str(a.n_samples) for a in axes]),
        ("bias, gravity removed [mg]", [_cell(f.accel_bias_mg) for f in figs]),
        ("  gravity removed [m/s^2]", [_cell(f.gravity_removed_m_s2, 6) for f in figs]),
        ("VRW read-off [m/s/sqrt(h)]", [("<= " if f.vrw_upper_bound else "")
                                        + _cell(f.vrw_m_s_rt_h) for f in figs]),
        ("  interval [m/s/sqrt(h)]", [_interval_cell(f.vrw_ci_m_s_rt_h) for f in figs]),
        ("  from tau [s]", [_cell(a.figures.arw_tau_range_s[0], 3) + "-"
                            + _cell(a.figures.arw_tau_range_s[1], 3) for a in axes]),
        ("  as density [m/s^2/sqrt(Hz)]", [_cell(f.vrw_m_s2_rt_hz) for f in figs]),
        ("bias instability read-off [ug]", [_cell(f.bias_instability_ug) for f in figs]),
        ("  interval [ug]", [_interval_cell(f.bias_instability_ci_ug) for f in figs]),
        ("  at tau [s]", [_cell(f.bias_instability_tau_s) for f in figs]),
        *((label, [_fit_cell(a.fit, term) for a in axes]) for term, label in _FIT_ROWS),
        ("tones", [str(len(a.tones)) if a.tones else "none" for a in axes]),
    ]
    width = max(len(label) for label, _ in rows)
    col = max(14, *(len(a.name) for a in axes), *(len(v) for _, vals in rows for v in vals))
    lines = [f"accelerometers (the same Allan analysis in m/s^2); read-off intervals at "
             f"{confidence:.1%}",
             " " * width + "  " + "  ".join(f"{a.name:>{col}}" for a in axes)]
    lines += [f"{label:<{width}}  " + "  ".join(f"{v:>{col}}" for v in vals)
              for label, vals in rows]
    for a, f in zip(axes, figs, strict=True):
        lines += [f"tone ({a.name}): {t.describe('m/s^2')}" for t in a.tones]
        lines += [f"note ({a.name}): {n}" for n in f.notes]
        lines += [f"fit note ({a.name}): {n}" for n in a.fit.notes]
    return "\n".join(lines)
