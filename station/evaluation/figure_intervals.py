"""A graded figure's value with its two-sided confidence interval, from one axis' rate and its
Allan analysis: the bias by batch means, bias stability by chi-square, the read-offs (IEEE 952
Annex C) by the edf of the Allan values they are read from, the fitted terms by their
standard errors."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from analysis.allan import blocks
from analysis.allan.confidence import chi2_interval
from analysis.allan.partial_clusters import white_level
from analysis.distributions import normal_ppf, t_ppf
from analysis.figures.readoffs import BIAS_INSTABILITY_FACTOR, arw_readoff, bias_instability_readoff
from analysis.figures.spec import bias_stability
from analysis.fit.least_squares import NoiseCoefficients
from analysis.units.conversions import S_PER_H
from station.evaluation.analyze import AxisAnalysis
from station.evaluation.readings import FIT_TERM as _FIT_TERM
from station.model.profiles import DEFAULT_FIGURE_SOURCE, bias_stability_average_s
from station.model.quantization import BIAS_BATCHES


@dataclass(frozen=True)
class Interval:
    """A figure in its canonical unit with its two-sided confidence interval (None if unknown)."""

    value: float | None
    low: float | None
    high: float | None
    note: str = ""


def normal_quantile(confidence: float) -> float:
    """The two-sided normal quantile of a confidence level (1.96 at 0.95)."""
    return float(normal_ppf(0.5 + confidence / 2))


def _chi2_scaled(value: float, edf: float, confidence: float) -> tuple[float, float]:
    """Interval of a deviation ``value`` whose variance has ``edf`` degrees of freedom."""
    low, high = chi2_interval(1.0, edf, confidence)
    return value * math.sqrt(float(low)), value * math.sqrt(float(high))


def bias_interval(x: np.ndarray, confidence: float) -> Interval:
    """``|mean|`` (deg/h) of the present samples of a rate record (deg/s; NaN where a
    sample is missing) with its batch-means interval. A long record (a memmap) is read a
    block at a time (:mod:`analysis.allan.blocks`): the same numbers, bit for bit where it has
    no gap."""
    if blocks.is_long(len(x)):
        mean = blocks.nan_mean(x) * S_PER_H
        means = blocks.finite_batch_means(x, BIAS_BATCHES) * S_PER_H
    else:
        x = x[np.isfinite(x)]
        mean = float(np.mean(x)) * S_PER_H
        size = len(x) // BIAS_BATCHES
        means = x[: size * BIAS_BATCHES].reshape(BIAS_BATCHES, size).mean(axis=1) * S_PER_H
    half = float(t_ppf(0.5 + confidence / 2, BIAS_BATCHES - 1)) * float(
        np.std(means, ddof=1)) / math.sqrt(BIAS_BATCHES)
    low, high = mean - half, mean + half
    if low <= 0 <= high:
        return Interval(abs(mean), 0.0, max(-low, high), "interval includes zero bias")
    return Interval(abs(mean), min(abs(low), abs(high)), max(abs(low), abs(high)))


def _readoff_interval(analysis: AxisAnalysis, name: str, confidence: float) -> Interval:
    allan = analysis.allan
    if name == "arw":
        r = arw_readoff(allan, analysis.fit, zones=analysis.zones)
        where = f"tau {r.tau_low_s:.3g}-{r.tau_high_s:.3g} s" if r.tau_low_s is not None else ""
    else:
        r = bias_instability_readoff(allan, zones=analysis.zones)
        where = f"at tau {r.tau_low_s:.3g} s" if r.tau_low_s is not None else ""
    if r.value is None:
        return Interval(None, None, None, r.note)
    scale = BIAS_INSTABILITY_FACTOR if name == "adev_min" else 1.0
    low, high = r.interval(confidence)
    assert low is not None and high is not None
    return Interval(r.value * scale, low * scale, high * scale, r.note or where)


def _fit_interval(fit: NoiseCoefficients, term: str, confidence: float) -> Interval:
    value, err = fit.values[term], fit.stderr[term]
    if value is None:
        why = "negative variance term" if term in fit.negative_terms else "not fitted"
        return Interval(None, None, None, f"not estimable ({why})")
    if err is None or not math.isfinite(err):
        return Interval(value, None, None, "no standard error")
    half = normal_quantile(confidence) * err
    return Interval(value, max(value - half, 0.0), value + half)


def figure_interval(name: str, x: np.ndarray, analysis: AxisAnalysis, confidence: float, *,
                    source: str = DEFAULT_FIGURE_SOURCE) -> Interval:
    """A figure (canonical unit) with its interval from one axis' rate (deg/s) and analysis.

    ``x`` is the rate the analysis worked on (:attr:`AxisAnalysis.rate_deg_s`: NaN where a
    sample is missing, spikes removed, Earth rate taken off where the bench gives it).
    ``source`` (``"read-off"`` or ``"fit"``) says where ``arw`` and ``bias_instability``
    come from (the profile's ``[grading] figure_source``).
    """
    average_s = bias_stability_average_s(name)
    if average_s is not None:
        bs = bias_stability(x, analysis.sample_rate_hz, average_s,
                            white_level=white_level(analysis.allan))
        if bs.value_deg_h is None:
            return Interval(
                None, None, None, f"only {bs.n_averages} averages of {average_s:g} s, needs 3"
            )
        edf = bs.n_averages - 1 if bs.edf is None else bs.edf
        low, high = _chi2_scaled(bs.value_deg_h, edf, confidence)
        partial = (f", {bs.missing_share:.1%} of their samples missing, edf {edf:.3g}"
                   if bs.missing_share else "")
        return Interval(bs.value_deg_h, low, high, f"{bs.n_averages} averages{partial}")
    if name == "bias":
        b = bias_interval(x, confidence)
        removed = analysis.figures.earth_rate_removed_deg_h
        earth = (
            "Earth rate not removed"
            if removed is None
            else f"Earth rate {removed:+.4g} deg/h removed"
        )
        return replace(b, note="; ".join(t for t in (b.note, earth) if t))
    if name in ("arw", "bias_instability") and source == "fit":
        return _fit_interval(analysis.fit, _FIT_TERM[f"{name}_fit"], confidence)
    if name in ("arw", "bias_instability", "adev_min"):
        return _readoff_interval(analysis, name, confidence)
    return _fit_interval(analysis.fit, _FIT_TERM[name], confidence)
