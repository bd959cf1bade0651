"""Bias versus temperature: points from plateaus or ramps, the sensitivity fit, hysteresis.

The temperature sensitivity of the bias (IEEE Std 952-1997 and IEEE Std 1431-2004, the
drift rate temperature sensitivity test: bias measured at stabilized temperatures across
the operating range, or during a controlled ramp) is the slope of bias against
temperature, deg/h per degC; with enough temperatures a quadratic term too. Where the
same temperature is passed going up and going down, the difference of the biases is the
thermal hysteresis.

* :func:`plateau_point`: one (temperature, bias) point from a record at a stable
  temperature.
* :func:`ramp_points`: points from a record during a ramp, in temperature bins, with the
  ramp's direction.
* :func:`fit_temperature_sensitivity`: weighted least squares of bias on temperature,
  linear or quadratic, with intervals; points of several switch-ons each get their own
  bias.
* :func:`hysteresis`: the largest up-minus-down bias difference at a common temperature.

A gyro powered again takes a new turn-on bias (the turn-on to turn-on repeatability,
IEEE Std 952-1997 and IEEE Std 1431-2004): points measured after different switch-ons
(a test interrupted and resumed, the unit switched on again) are not on one line. The fit
is then a fixed-effects regression, ``bias_i = b_s(i) + c1 (T_i - T_ref) [+ c2 (...)^2]``,
an intercept per switch-on ``s`` and one sensitivity: only the temperature differences
within a switch-on tell the slope, and a switch-on with one point tells only its own
bias. Hysteresis pairs points of the same switch-on only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.errors import TooFewSamplesError
from analysis.sequences.cycle_stats import check_confidence, t_half_width
from analysis.sequences.turn_on import BIAS_BATCHES
from analysis.units.conversions import S_PER_H

Direction = Literal["up", "down", "plateau"]


@dataclass(frozen=True)
class TemperaturePoint:
    """Mean bias at one temperature.

    Attributes
    ----------
    temperature_c : float
        Mean temperature of the samples, degC.
    bias_deg_h : float
        Mean rate, deg/h.
    stderr_deg_h : float
        Standard error of the mean (batch means), deg/h.
    direction : {"up", "down", "plateau"}
        Whether the temperature was rising, falling or steady.
    n_samples : int
        Samples averaged.
    switch_on : int or None
        The switch-on the point was measured after (its number; None: unknown, one for all
        such points).
    """

    temperature_c: float
    bias_deg_h: float
    stderr_deg_h: float
    direction: Direction
    n_samples: int
    switch_on: int | None = None


def _mean_and_stderr(x: NDArray[np.float64]) -> tuple[float, float]:
    size = x.size // BIAS_BATCHES
    if size < 2:
        raise TooFewSamplesError(f"{x.size} samples: a bias with a batch-means error needs "
                                 f"at least {2 * BIAS_BATCHES}")
    means = x[:size * BIAS_BATCHES].reshape(BIAS_BATCHES, size).mean(axis=1)
    return float(x.mean()), float(means.std(ddof=1)) / math.sqrt(BIAS_BATCHES)


def _paired(rate_deg_s: ArrayLike, temperature_c: ArrayLike
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    x = np.asarray(rate_deg_s, dtype=np.float64)
    temp = np.asarray(temperature_c, dtype=np.float64)
    if x.ndim != 1 or temp.shape != x.shape:
        raise ValueError(f"rate and temperature must be one axis of equal length, got shapes "
                         f"{x.shape} and {temp.shape}")
    keep = np.isfinite(x) & np.isfinite(temp)
    return x[keep], temp[keep]


def plateau_point(rate_deg_s: ArrayLike, temperature_c: ArrayLike, *,
                  switch_on: int | None = None) -> TemperaturePoint:
    """The mean bias (deg/h) and temperature (degC) of a record at a steady temperature,
    measured after switch-on ``switch_on``.

    Raises
    ------
    TooFewSamplesError
        Fewer than ``2 * BIAS_BATCHES`` samples with both a rate and a temperature.
    """
    x, temp = _paired(rate_deg_s, temperature_c)
    mean, err = _mean_and_stderr(x)
    return TemperaturePoint(float(temp.mean()), mean * S_PER_H, err * S_PER_H, "plateau",
                            int(x.size), switch_on)


def ramp_points(rate_deg_s: ArrayLike, temperature_c: ArrayLike, *, bin_c: float,
                min_samples: int = 200, switch_on: int | None = None
                ) -> tuple[TemperaturePoint, ...]:
    """Points of a record taken while the temperature changes: one per ``bin_c`` degC
    (measured after switch-on ``switch_on``).

    Samples are binned by temperature; each bin with at least ``min_samples`` samples
    gives a point. The direction of each bin is the sign of the temperature's trend over
    the samples in it (a linear fit of temperature on sample index).

    Raises
    ------
    ValueError
        ``bin_c`` not a positive number.
    """
    if not (math.isfinite(bin_c) and bin_c > 0):
        raise ValueError(f"bin_c must be a finite number > 0, got {bin_c}")
    x, temp = _paired(rate_deg_s, temperature_c)
    if x.size == 0:
        return ()
    index = np.arange(x.size, dtype=np.float64)
    bins = np.floor(temp / bin_c).astype(np.int64)
    points = []
    for b in np.unique(bins):
        inside = bins == b
        if int(inside.sum()) < max(min_samples, 2 * BIAS_BATCHES):
            continue
        mean, err = _mean_and_stderr(x[inside])
        slope = np.polyfit(index[inside], temp[inside], 1)[0] if inside.sum() > 1 else 0.0
        direction: Direction = "up" if slope > 0 else "down" if slope < 0 else "plateau"
        points.append(TemperaturePoint(float(temp[inside].mean()), mean * S_PER_H, err * S_PER_H,
                                       direction, int(inside.sum()), switch_on))
    return tuple(points)


@dataclass(frozen=True)
class TemperatureFit:
    """Bias against temperature, ``b(T) = c0 + c1 (T - T_ref) [+ c2 (T - T_ref)^2]``.

    Attributes
    ----------
    order : int
        1 (linear) or 2 (quadratic).
    reference_c : float
        ``T_ref``, degC (the mean temperature of the points unless given).
    coefficients : tuple of float
        ``(c0 deg/h, c1 deg/h/degC[, c2 deg/h/degC^2])``.
    stderr : tuple of float
        Their standard errors (scaled by the Birge ratio ``sqrt(chi2 / dof)`` when the
        points scatter more than their own errors say).
    ci_low, ci_high : tuple of float
        Two-sided intervals (Student t with ``dof`` degrees of freedom; normal when
        ``dof`` is 0).
    dof : int
        Points minus coefficients.
    chi2_reduced : float or None
        Weighted residual sum of squares over ``dof`` (None when ``dof`` is 0).
    n_points : int
        Points fitted.
    confidence : float
        Two-sided level.
    switch_ons : tuple
        The switch-ons of the points, in order of first appearance (one ``None`` when the
        points carry none); ``c0`` is the first's bias at ``T_ref``.
    intercepts_deg_h, intercepts_stderr_deg_h : tuple of float
        Each switch-on's bias at ``T_ref`` and its standard error, deg/h (the first is
        ``c0``).
    """

    order: int
    reference_c: float
    coefficients: tuple[float, ...]
    stderr: tuple[float, ...]
    ci_low: tuple[float, ...]
    ci_high: tuple[float, ...]
    dof: int
    chi2_reduced: float | None
    n_points: int
    confidence: float
    switch_ons: tuple[int | None, ...] = (None,)
    intercepts_deg_h: tuple[float, ...] = ()
    intercepts_stderr_deg_h: tuple[float, ...] = ()

    @property
    def slope_deg_h_per_c(self) -> float:
        """``c1``: the bias sensitivity at ``T_ref``, deg/h per degC."""
        return self.coefficients[1]

    def bias_deg_h(self, temperature_c: ArrayLike, switch_on: int | None = None
                   ) -> NDArray[np.float64]:
        """The fitted bias (deg/h) at ``temperature_c`` (degC), of switch-on ``switch_on``
        (default the first)."""
        dt = np.asarray(temperature_c, dtype=np.float64) - self.reference_c
        c0 = (self.intercepts_deg_h[self.switch_ons.index(switch_on)]
              if switch_on is not None and switch_on in self.switch_ons
              else self.coefficients[0])
        return np.asarray(c0 + sum(c * dt ** k for k, c in enumerate(self.coefficients)
                                   if k > 0), dtype=np.float64)


def fit_temperature_sensitivity(points: Sequence[TemperaturePoint], *, order: int = 1,
                                reference_c: float | None = None, confidence: float = 0.95,
                                error_floor_deg_h: float = 0.0) -> TemperatureFit:
    """Weighted least squares of bias on temperature, a bias per switch-on.

    Each point is weighted by its inverse variance (``stderr**2 + error_floor**2``). Points
    of different switch-ons (:attr:`TemperaturePoint.switch_on`) each get their own
    intercept (a fixed-effects regression; see the module doc): one sensitivity, fitted to
    the temperature differences within each switch-on. When there are more points than
    parameters, the covariance is scaled up by the reduced chi-square of the pooled
    residuals if that exceeds one (the points scatter more than their errors: a model the
    data do not follow, or slow drifts between plateaus), and the intervals are Student t
    with the residual degrees of freedom (points less intercepts less the ``order``
    temperature coefficients).

    Parameters
    ----------
    points : sequence of TemperaturePoint
        Plateau or ramp points.
    order : {1, 2}
        Linear or quadratic.
    reference_c : float, optional
        ``T_ref`` (degC); default the mean temperature of the points.
    confidence : float
        Two-sided level of the intervals.
    error_floor_deg_h : float
        Added in quadrature to every point's standard error (deg/h): a point whose own
        error is tiny would otherwise outweigh the rest.

    Returns
    -------
    TemperatureFit

    Raises
    ------
    TooFewSamplesError
        Too few distinct temperatures (0.01 degC apart) within the switch-ons for the
        coefficients: the distinct temperatures less one per switch-on must be at least
        ``order``.
    ValueError
        ``order`` not 1 or 2, or ``confidence`` outside (0, 1).
    """
    check_confidence(confidence)
    if order not in (1, 2):
        raise ValueError(f"order must be 1 (linear) or 2 (quadratic), got {order}")
    temps = np.array([p.temperature_c for p in points], dtype=np.float64)
    bias = np.array([p.bias_deg_h for p in points], dtype=np.float64)
    err = np.array([p.stderr_deg_h for p in points], dtype=np.float64)
    groups = list(dict.fromkeys(p.switch_on for p in points))
    member = np.array([groups.index(p.switch_on) for p in points], dtype=np.int64)
    n_groups = len(groups)
    # what tells the coefficients: the distinct temperatures beyond the first of each group
    informative = sum(len(np.unique(np.round(temps[member == g], 2))) - 1
                      for g in range(n_groups))
    if informative < order:
        raise TooFewSamplesError(
            f"{informative + n_groups} distinct temperature(s) in {n_groups} switch-on(s): a "
            f"fit of order {order} needs at least {order + 1} within one switch-on, or "
            f"{order} more than its switch-ons")
    ref = float(temps.mean()) if reference_c is None else float(reference_c)
    sigma = np.sqrt(err ** 2 + error_floor_deg_h ** 2)
    sigma = np.where(sigma > 0, sigma, max(float(sigma.max()), 1e-12))
    design = np.hstack([(member[:, None] == np.arange(n_groups)[None, :]).astype(np.float64),
                        np.vander(temps - ref, order + 1, increasing=True)[:, 1:]])
    w = 1.0 / sigma
    params, *_ = np.linalg.lstsq(design * w[:, None], bias * w, rcond=None)
    cov = np.linalg.inv((design * (w ** 2)[:, None]).T @ design)
    dof = len(points) - n_groups - order
    chi2_red = None
    if dof > 0:
        resid = (bias - design @ params) * w
        chi2_red = float(resid @ resid) / dof
        cov = cov * max(1.0, chi2_red)
    se_all = np.sqrt(np.diag(cov))
    pick = [0, *range(n_groups, n_groups + order)]  # c0 (the first switch-on's), c1[, c2]
    coef, se = params[pick], se_all[pick]
    half = np.array([t_half_width(float(v), dof, confidence) for v in se])
    return TemperatureFit(order, ref, tuple(float(c) for c in coef),
                          tuple(float(v) for v in se), tuple(float(c) for c in coef - half),
                          tuple(float(c) for c in coef + half), dof, chi2_red, len(points),
                          confidence, tuple(groups),
                          tuple(float(c) for c in params[:n_groups]),
                          tuple(float(v) for v in se_all[:n_groups]))


@dataclass(frozen=True)
class Hysteresis:
    """The largest bias difference between rising and falling temperature.

    Attributes
    ----------
    value_deg_h : float
        ``max |b_up(T) - b_down(T)|`` over the temperatures both directions reached, deg/h.
    stderr_deg_h : float
        Standard error of that difference, deg/h.
    temperature_c : float
        Where the largest difference is, degC.
    n_pairs : int
        Temperatures compared.
    """

    value_deg_h: float
    stderr_deg_h: float
    temperature_c: float
    n_pairs: int


def hysteresis(points: Sequence[TemperaturePoint], *, tolerance_c: float = 0.5,
               slope_deg_h_per_c: float = 0.0) -> Hysteresis | None:
    """Hysteresis between the points reached going up and those reached going down.

    A plateau point is "up" when its temperature is above the previous point's, "down"
    when below (the order of ``points`` is the order of the test); ramp points carry their
    direction. An up point and a down point of the same switch-on within ``tolerance_c``
    of each other form a pair (points of two switch-ons differ by their turn-on biases
    too); their bias difference is taken at a common temperature with the sensitivity
    ``slope_deg_h_per_c`` (the fitted slope). None when no pair exists.
    """
    directed: list[tuple[Direction, TemperaturePoint]] = []
    previous: float | None = None
    for p in points:
        d = p.direction
        if d == "plateau" and previous is not None:
            d = ("up" if p.temperature_c > previous + tolerance_c else
                 "down" if p.temperature_c < previous - tolerance_c else "plateau")
        directed.append((d, p))
        previous = p.temperature_c
    ups = [p for d, p in directed if d == "up"]
    downs = [p for d, p in directed if d == "down"]
    best: Hysteresis | None = None
    n = 0
    for u in ups:
        near = [q for q in downs if abs(q.temperature_c - u.temperature_c) <= tolerance_c
                and q.switch_on == u.switch_on]
        if not near:
            continue
        down = min(near, key=lambda q: abs(q.temperature_c - u.temperature_c))
        n += 1
        diff = abs(u.bias_deg_h - down.bias_deg_h
                   - slope_deg_h_per_c * (u.temperature_c - down.temperature_c))
        if best is None or diff > best.value_deg_h:
            best = Hysteresis(diff, math.hypot(u.stderr_deg_h, down.stderr_deg_h),
                              (u.temperature_c + down.temperature_c) / 2, 0)
    if best is None:
        return None
    return Hysteresis(best.value_deg_h, best.stderr_deg_h, best.temperature_c, n)
