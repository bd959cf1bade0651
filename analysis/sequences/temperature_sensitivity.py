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
  linear or quadratic, with intervals.
* :func:`hysteresis`: the largest up-minus-down bias difference at a common temperature.
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
    """

    temperature_c: float
    bias_deg_h: float
    stderr_deg_h: float
    direction: Direction
    n_samples: int


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


def plateau_point(rate_deg_s: ArrayLike, temperature_c: ArrayLike) -> TemperaturePoint:
    """The mean bias (deg/h) and temperature (degC) of a record at a steady temperature.

    Raises
    ------
    TooFewSamplesError
        Fewer than ``2 * BIAS_BATCHES`` samples with both a rate and a temperature.
    """
    x, temp = _paired(rate_deg_s, temperature_c)
    mean, err = _mean_and_stderr(x)
    return TemperaturePoint(float(temp.mean()), mean * S_PER_H, err * S_PER_H, "plateau",
                            int(x.size))


def ramp_points(rate_deg_s: ArrayLike, temperature_c: ArrayLike, *, bin_c: float,
                min_samples: int = 200) -> tuple[TemperaturePoint, ...]:
    """Points of a record taken while the temperature changes: one per ``bin_c`` degC.

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
                                       direction, int(inside.sum())))
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

    @property
    def slope_deg_h_per_c(self) -> float:
        """``c1``: the bias sensitivity at ``T_ref``, deg/h per degC."""
        return self.coefficients[1]

    def bias_deg_h(self, temperature_c: ArrayLike) -> NDArray[np.float64]:
        """The fitted bias (deg/h) at ``temperature_c`` (degC)."""
        dt = np.asarray(temperature_c, dtype=np.float64) - self.reference_c
        return np.asarray(sum(c * dt ** k for k, c in enumerate(self.coefficients)),
                          dtype=np.float64)


def fit_temperature_sensitivity(points: Sequence[TemperaturePoint], *, order: int = 1,
                                reference_c: float | None = None, confidence: float = 0.95,
                                error_floor_deg_h: float = 0.0) -> TemperatureFit:
    """Weighted least squares of bias on temperature.

    Each point is weighted by its inverse variance (``stderr**2 + error_floor**2``). When
    there are more points than coefficients, the covariance is scaled up by the reduced
    chi-square if that exceeds one (the points scatter more than their errors: a model
    the data do not follow, or slow drifts between plateaus), and the intervals are
    Student t with the residual degrees of freedom.

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
        Fewer distinct temperatures (0.01 degC apart) than coefficients.
    ValueError
        ``order`` not 1 or 2, or ``confidence`` outside (0, 1).
    """
    check_confidence(confidence)
    if order not in (1, 2):
        raise ValueError(f"order must be 1 (linear) or 2 (quadratic), got {order}")
    temps = np.array([p.temperature_c for p in points], dtype=np.float64)
    bias = np.array([p.bias_deg_h for p in points], dtype=np.float64)
    err = np.array([p.stderr_deg_h for p in points], dtype=np.float64)
    n_coef = order + 1
    distinct = len(np.unique(np.round(temps, 2)))
    if distinct < n_coef:
        raise TooFewSamplesError(f"{distinct} distinct temperature(s): a fit of order {order} "
                                 f"needs at least {n_coef}")
    ref = float(temps.mean()) if reference_c is None else float(reference_c)
    sigma = np.sqrt(err ** 2 + error_floor_deg_h ** 2)
    sigma = np.where(sigma > 0, sigma, max(float(sigma.max()), 1e-12))
    design = np.vander(temps - ref, n_coef, increasing=True)
    w = 1.0 / sigma
    coef, *_ = np.linalg.lstsq(design * w[:, None], bias * w, rcond=None)
    cov = np.linalg.inv((design * (w ** 2)[:, None]).T @ design)
    dof = len(points) - n_coef
    chi2_red = None
    if dof > 0:
        resid = (bias - design @ coef) * w
        chi2_red = float(resid @ resid) / dof
        cov = cov * max(1.0, chi2_red)
    se = np.sqrt(np.diag(cov))
    half = np.array([t_half_width(float(s), dof, confidence) for s in se])
    return TemperatureFit(order, ref, tuple(float(c) for c in coef),
                          tuple(float(s) for s in se), tuple(float(c) for c in coef - half),
                          tuple(float(c) for c in coef + half), dof, chi2_red, len(points),
                          confidence)


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
    direction. An up point and a down point within ``tolerance_c`` of each other form a
    pair; their bias difference is taken at a common temperature with the sensitivity
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
        near = [q for q in downs if abs(q.temperature_c - u.temperature_c) <= tolerance_c]
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
