"""The dynamic Allan deviation heat map of a run's axis, as every view draws it.

The spec sheets (PDF, HTML) and the TUI's spec sheet show the same map: the windows, step
and taus come from :class:`station.evaluation.settings.AnalysisSettings` and the grid is
computed here once (:func:`davar_grid`); only the drawing differs.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan import blocks
from analysis.allan.estimators import log_m
from analysis.davar.estimators import dynamic_allan_variance, plan_davar
from analysis.davar.long import dynamic_allan_variance_long, group_span
from analysis.errors import InvalidWindowError, TooFewSamplesError
from analysis.units.conversions import S_PER_H
from station.evaluation.accel_axes import accel_record
from station.evaluation.grading import UnitGrade
from station.evaluation.settings import AnalysisSettings
from station.storage.scratch import scratch_array


@dataclass(frozen=True)
class DavarGrid:
    """Dynamic Allan deviation of one axis, ready for a heat map.

    Attributes
    ----------
    axis : str
        Axis name.
    t_s : ndarray, shape (n_windows,)
        Window centre times in s from the start of the record (increasing).
    tau_s : ndarray, shape (n_tau,)
        Averaging times in s (increasing).
    adev_deg_h : ndarray, shape (n_windows, n_tau)
        Allan deviation in deg/h per window and tau; NaN where a window has no value.
    window_s : float
        Window length in s.
    warmup_s : float
        Warm-up the grading discarded, s from the start of the record (0: none); the map
        marks where it ends.

    Raises
    ------
    ValueError
        If the shapes do not agree or there is no window or tau.
    """

    axis: str
    t_s: NDArray[np.float64]
    tau_s: NDArray[np.float64]
    adev_deg_h: NDArray[np.float64]
    window_s: float
    warmup_s: float = 0.0

    def __post_init__(self) -> None:
        t, tau = np.asarray(self.t_s), np.asarray(self.tau_s)
        shape = np.shape(self.adev_deg_h)
        if t.ndim != 1 or tau.ndim != 1 or not len(t) or not len(tau):
            raise ValueError("t_s and tau_s must be non-empty 1-D arrays")
        if shape != (len(t), len(tau)):
            raise ValueError(f"adev_deg_h must be (n_windows, n_tau) = {(len(t), len(tau))}, "
                             f"got {shape}")


def davar_plan(n_samples: int, settings: AnalysisSettings | None = None) -> tuple[int, int]:
    """Window and step (samples) of the heat map's DAVAR (:meth:`AnalysisSettings.davar_plan`)."""
    return (settings or AnalysisSettings()).davar_plan(n_samples)


def davar_grid_of(rate_deg_s: ArrayLike, sample_rate_hz: float, axis: str = "", *,
                  settings: AnalysisSettings | None = None) -> DavarGrid | None:
    """The DAVAR of one axis's rate (deg/s, shape (N,)) for the heat map, in the windows of
    :meth:`AnalysisSettings.davar_plan` at ``davar_taus`` log-spaced taus (the fast DAVAR,
    compiled when numba is installed); None when the record is too short for one window
    of 9 samples. A constant record gets an ADEV of exactly 0 (not the rounding residue of
    its mean).

    Raises
    ------
    AnalysisError
        If the samples are not finite or the sample rate is invalid (not "too short").
    """
    settings = settings or AnalysisSettings()
    rate = np.asarray(rate_deg_s, dtype=np.float64)
    if rate.ndim != 1:
        raise ValueError(f"rate_deg_s must be one axis, shape (N,), got {rate.shape}")
    window, step = settings.davar_plan(len(rate))
    m = log_m(window, n_points=settings.davar_taus) if window else np.zeros(0, np.int64)
    if not m.size:
        return None
    fs = float(sample_rate_hz)
    long = blocks.is_long(len(rate))
    gapped = blocks.any_where(rate, np.isnan) if long else bool(np.isnan(rate).any())
    try:
        if long:  # a group of windows at a time, its angle in a scratch memmap
            plan = plan_davar(fs, window / fs, step / fs, m / fs)
            result = dynamic_allan_variance_long(
                rate, fs, window_s=window / fs, step_s=step / fs, taus=m / fs,
                missing="gap" if gapped else "raise",
                angle_out=scratch_array((group_span(plan) + 1,))).axis(0)
        else:
            result = dynamic_allan_variance(rate, fs, window_s=window / fs, step_s=step / fs,
                                            taus=m / fs, missing="gap" if gapped else "raise")
    except (TooFewSamplesError, InvalidWindowError):
        return None
    adev = result.adev * S_PER_H
    if _constant(rate, long):
        adev = np.zeros_like(adev)
    return DavarGrid(axis, result.t_s, result.tau_s, adev, result.window_s)


def _constant(rate: NDArray[np.float64], long: bool) -> bool:
    """Whether every sample present (not NaN) of a record holds one value."""
    if not long:
        present = rate[~np.isnan(rate)]
        return bool(present.size and np.all(present == present[0]))
    first = None
    for a, b in blocks.spans(0, len(rate)):
        v = np.asarray(rate[a:b])
        present = v[~np.isnan(v)]
        blocks.release(rate)
        if present.size:
            first = float(present[0])
            break
    return first is not None and not blocks.any_where(
        rate, lambda v: ~np.isnan(v) & (v != first))


def davar_grid(unit: UnitGrade, axis_index: int = 0, *,
               settings: AnalysisSettings | None = None) -> DavarGrid | None:
    """The heat map's DAVAR of a graded unit's axis over its whole record (warm-up
    included: it is what the DAVAR shows, and the map marks where the discarded warm-up
    ends); None when the record is too short."""
    record = unit.unit.record
    axis = unit.axes[axis_index]
    if axis.analysis.accel is not None and axis.axis in record.accel_axis_names:
        accel = accel_record(record.select_accel(axis.axis))  # its m/s^2 in the rate's place
        assert accel is not None
        record, column = accel, 0
    else:
        column = (record.axis_names.index(axis.axis) if axis.axis in record.axis_names
                  else axis_index)
    long = record.sample_index is not None and blocks.is_long(record.span_samples)
    rate = record.gridded(column, out=scratch_array((record.span_samples,)) if long else None)
    grid = davar_grid_of(rate, record.sample_rate_hz, axis.axis, settings=settings)
    return None if grid is None else replace(grid, warmup_s=unit.warmup_discarded_s)
