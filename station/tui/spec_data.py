"""What the spec-sheet screen draws, computed from a graded unit (no widgets here).

The same quantities as the report panels (:mod:`station.output.report.panels`), as
:class:`~station.tui.live.Series` for a terminal plot: the measured Allan deviation of
each axis with its fitted model and the fitted terms as their slope lines, the deciding
grade's limit lines, and the DAVAR as a grid of Allan deviation over window time and tau
(drawn by :mod:`station.tui.heatmap`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan import log_m
from analysis.errors import InvalidWindowError, TooFewSamplesError
from analysis.fit import TERMS
from analysis.units import S_PER_H
from station.evaluation.grading import AxisGrade, UnitGrade, run_profile_ref
from station.model.profiles import available_profiles, load_profile
from station.model.runs import RunInfo
from station.tui.live import Series

#: The DAVAR heat map: at most this many windows, a step of half a window; each window
#: at least this many samples (taus over two decades); this many log-spaced taus (a
#: terminal map has 2 pixels a row: 48 fill 24 rows, and cost half of the default 100).
DAVAR_WINDOWS = 40
DAVAR_MIN_WINDOW_SAMPLES = 900
DAVAR_TAUS = 48


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


def davar_plan(n_samples: int, *, max_windows: int = DAVAR_WINDOWS,
               min_window_samples: int = DAVAR_MIN_WINDOW_SAMPLES) -> tuple[int, int]:
    """Window and step (samples) of the heat map's DAVAR: the step is half a window and
    the windows cover the record; as many windows as ``max_windows`` allows while each
    keeps ``min_window_samples`` (one window of the whole record when it is shorter than
    two of those). ``(0, 0)`` when the record has fewer than 2 samples."""
    if n_samples < 2:
        return 0, 0
    n_windows = max(1, min(max_windows, 2 * n_samples // max(1, min_window_samples) - 1))
    step = n_samples // (n_windows + 1)
    return 2 * step, step


def davar_grid_of(rate_deg_s: ArrayLike, sample_rate_hz: float, axis: str = "", *,
                  max_windows: int = DAVAR_WINDOWS) -> DavarGrid | None:
    """The DAVAR of one axis's rate (deg/s, shape (N,)) for the heat map, in windows of
    :func:`davar_plan` and :data:`DAVAR_TAUS` log-spaced taus (the fast DAVAR, compiled
    when numba is installed); None when the record is too short for one window of 9
    samples. A constant record gets an ADEV of exactly 0 (not the rounding residue of
    its mean).

    Raises
    ------
    AnalysisError
        If the samples are not finite or the sample rate is invalid (not "too short").
    """
    from analysis.davar import dynamic_allan_variance

    rate = np.asarray(rate_deg_s, dtype=np.float64)
    if rate.ndim != 1:
        raise ValueError(f"rate_deg_s must be one axis, shape (N,), got {rate.shape}")
    window, step = davar_plan(len(rate), max_windows=max_windows)
    m = log_m(window, n_points=DAVAR_TAUS) if window else np.zeros(0, np.int64)
    if not m.size:
        return None
    fs = float(sample_rate_hz)
    try:
        result = dynamic_allan_variance(rate, fs, window_s=window / fs, step_s=step / fs,
                                        taus=m / fs)
    except (TooFewSamplesError, InvalidWindowError):
        return None
    adev = result.adev * S_PER_H
    if np.all(rate == rate[0]):
        adev = np.zeros_like(adev)
    return DavarGrid(axis, result.t_s, result.tau_s, adev, result.window_s)


def davar_grid(unit: UnitGrade, axis_index: int = 0) -> DavarGrid | None:
    """The heat map's DAVAR of a graded unit's axis over its whole record (warm-up
    included: it is what the DAVAR shows); None when the record is too short."""
    record = unit.unit.record
    axis = unit.axes[axis_index]
    column = record.axis_names.index(axis.axis) if axis.axis in record.axis_names else axis_index
    grid = davar_grid_of(record.rate_deg_s[:, column], record.sample_rate_hz, axis.axis)
    return None if grid is None else replace(grid, warmup_s=unit.warmup_discarded_s)


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
