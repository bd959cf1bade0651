"""Summaries of a quantity measured once per power cycle: mean and spread with intervals.

A sequence of power cycles gives one value per cycle (a mean bias, a turn-on time, a
warm-up time). Across cycles the values are taken as independent draws of one normal
variable: the mean's interval is Student's t with ``n - 1`` degrees of freedom, the
standard deviation's interval the chi-square interval with ``n - 1`` degrees of freedom
(the turn-on to turn-on repeatability of IEEE Std 952-1997 and IEEE Std 1431-2004 is
this standard deviation of the per-cycle mean biases).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.distributions import chi2_ppf, normal_ppf, t_ppf


@dataclass(frozen=True)
class CycleSummary:
    """Mean and standard deviation of per-cycle values, each with its two-sided interval.

    Attributes
    ----------
    values : ndarray, shape (n,)
        The finite per-cycle values, in the caller's unit.
    n : int
        Number of values.
    mean, mean_low, mean_high : float or None
        Mean and its Student-t interval (None for the bounds when ``n < 2``; None
        throughout when ``n == 0``).
    std, std_low, std_high : float or None
        Standard deviation (ddof = 1) and its chi-square interval with ``n - 1`` degrees
        of freedom (None when ``n < 2``).
    maximum : float or None
        The largest value (what an upper spec limit on a single turn-on faces).
    confidence : float
        Two-sided level of the intervals.
    """

    values: NDArray[np.float64]
    n: int
    mean: float | None
    mean_low: float | None
    mean_high: float | None
    std: float | None
    std_low: float | None
    std_high: float | None
    maximum: float | None
    confidence: float


def check_confidence(confidence: float) -> float:
    """``confidence`` as a float in (0, 1), else ValueError."""
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    return float(confidence)


def std_interval(std: float, dof: int, confidence: float) -> tuple[float, float]:
    """Chi-square interval of a standard deviation ``std`` estimated with ``dof`` degrees
    of freedom: ``std * sqrt(dof / chi2.ppf((1 +- c) / 2, dof))``.

    Raises
    ------
    ValueError
        ``dof < 1`` or ``confidence`` outside (0, 1).
    """
    check_confidence(confidence)
    if dof < 1:
        raise ValueError(f"a standard deviation needs >= 1 degree of freedom, got {dof}")
    upper = float(chi2_ppf(0.5 + confidence / 2.0, dof))
    lower = float(chi2_ppf(0.5 - confidence / 2.0, dof))
    return std * math.sqrt(dof / upper), std * math.sqrt(dof / lower)


def t_half_width(stderr: float, dof: int, confidence: float) -> float:
    """Half width of a Student-t interval: ``t.ppf((1 + c) / 2, dof) * stderr``
    (the normal quantile when ``dof`` is 0 or less: the standard error is then known,
    not estimated)."""
    check_confidence(confidence)
    q = (t_ppf(0.5 + confidence / 2.0, dof) if dof >= 1
         else normal_ppf(0.5 + confidence / 2.0))
    return float(q) * stderr


def summarize_cycles(values: ArrayLike, confidence: float = 0.95) -> CycleSummary:
    """Mean and spread of per-cycle values (NaN entries, cycles without a value, left out).

    Parameters
    ----------
    values : array_like, shape (n,)
        One value per cycle, any unit.
    confidence : float
        Two-sided level of the intervals.

    Returns
    -------
    CycleSummary

    Raises
    ------
    ValueError
        ``confidence`` outside (0, 1) or ``values`` not one-dimensional.
    """
    check_confidence(confidence)
    arr = np.asarray(values, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"values must be one-dimensional, got shape {arr.shape}")
    v = arr[np.isfinite(arr)]
    n = int(v.size)
    if n == 0:
        return CycleSummary(v, 0, None, None, None, None, None, None, None, confidence)
    mean = float(v.mean())
    if n < 2:
        return CycleSummary(v, 1, mean, None, None, None, None, None, float(v.max()), confidence)
    std = float(v.std(ddof=1))
    half = t_half_width(std / math.sqrt(n), n - 1, confidence)
    low, high = std_interval(std, n - 1, confidence)
    return CycleSummary(v, n, mean, mean - half, mean + half, std, low, high, float(v.max()),
                        confidence)
