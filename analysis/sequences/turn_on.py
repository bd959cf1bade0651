"""What a gyro does after it is switched on: its bias per turn-on, its warm-up, their spread.

The static tests of IEEE Std 952-1997 (interferometric fiber optic gyros) and IEEE Std
1431-2004 (Coriolis vibratory gyros) that need no rate table include, besides the noise
measurements, the *turn-on to turn-on bias repeatability* (the gyro is switched on,
allowed to warm up for a stated time, its bias measured, switched off and cooled,
repeated; the figure is the standard deviation of the biases), the *turn-on time*
(application of power to the first valid output) and the *warm-up time* (application of
power to the time after which the output stays within its specified performance, here a
stated band about the settled bias). This module computes them from one record per
power cycle; times are seconds since the application of power.

* :func:`cycle_bias`: a cycle's mean bias after its warm-up, with a batch-means standard
  error.
* :func:`warmup_curve`: the bias trend (sliding averages) and the time it enters the band
  about the settled bias for good.
* :func:`turn_on_repeatability`: the standard deviation of the per-cycle mean biases with
  its chi-square interval on ``N - 1`` degrees of freedom.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from analysis.allan.estimators import check_sample_rate
from analysis.errors import TooFewSamplesError
from analysis.sequences.cycle_stats import CycleSummary, summarize_cycles
from analysis.units.conversions import S_PER_H

#: Batches of a cycle's batch-means standard error of its bias.
BIAS_BATCHES = 10


def _rate_1d(rate_deg_s: ArrayLike) -> NDArray[np.float64]:
    x = np.asarray(rate_deg_s, dtype=np.float64)
    if x.ndim != 1:
        raise ValueError(f"rate must be one axis (shape (n,)), got shape {x.shape}")
    return x


def _positive(name: str, value: float) -> float:
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {value}")
    return float(value)


@dataclass(frozen=True)
class CycleBias:
    """The mean bias of one power cycle after its warm-up.

    Attributes
    ----------
    mean_deg_h : float
        Mean rate (deg/h) of the samples from ``after_s`` on (NaN samples, gaps, left out).
    stderr_deg_h : float or None
        Standard error of the mean from :data:`BIAS_BATCHES` batch means (None with fewer
        than two samples per batch).
    n_samples : int
        Samples averaged.
    after_s : float
        Start of the averaged stretch, s since power-on.
    """

    mean_deg_h: float
    stderr_deg_h: float | None
    n_samples: int
    after_s: float


def sample_times_s(n_samples: int, sample_rate_hz: float, first_s: float) -> NDArray[np.float64]:
    """Time since power-on (s) of each sample of a record on its sample grid: the first at
    ``first_s`` (s since power-on), then one sample period apart."""
    fs = check_sample_rate(sample_rate_hz)
    return first_s + np.arange(n_samples, dtype=np.float64) / fs


def cycle_bias(rate_deg_s: ArrayLike, sample_rate_hz: float, *, first_s: float,
               after_s: float) -> CycleBias:
    """A cycle's mean bias (deg/h) after its warm-up, with a batch-means standard error.

    Parameters
    ----------
    rate_deg_s : array_like, shape (n,)
        One axis of the cycle's record on its sample grid (NaN where a sample is missing).
    sample_rate_hz : float
        Sample rate, Hz.
    first_s : float
        Time of the first sample, s since power-on.
    after_s : float
        Samples before this time (s since power-on) are the warm-up and are left out.

    Returns
    -------
    CycleBias

    Raises
    ------
    TooFewSamplesError
        No finite sample after ``after_s``.
    """
    x = _rate_1d(rate_deg_s)
    t = sample_times_s(len(x), sample_rate_hz, first_s)
    kept = x[t >= after_s]
    kept = kept[np.isfinite(kept)]
    if kept.size == 0:
        raise TooFewSamplesError(f"no sample after {after_s:g} s from power-on (the record "
                                 f"ends {t[-1] if len(t) else first_s:.4g} s after it)")
    mean = float(kept.mean()) * S_PER_H
    size = kept.size // BIAS_BATCHES
    stderr = None
    if size >= 2:
        means = kept[:size * BIAS_BATCHES].reshape(BIAS_BATCHES, size).mean(axis=1) * S_PER_H
        stderr = float(means.std(ddof=1)) / math.sqrt(BIAS_BATCHES)
    return CycleBias(mean, stderr, int(kept.size), float(after_s))


@dataclass(frozen=True)
class WarmupCurve:
    """The bias trend of one cycle and its warm-up time.

    Attributes
    ----------
    t_s : ndarray, shape (k,)
        Centre of each sliding average, s since power-on.
    bias_deg_h : ndarray, shape (k,)
        Sliding averages of the rate, deg/h (NaN where a window holds less than half its
        samples).
    reference_deg_h : float
        The settled bias: the mean from ``reference_after_s`` to the end, deg/h.
    band_deg_h : float
        Half width of the band about the settled bias, deg/h.
    average_s : float
        Length of each sliding average, s.
    warmup_time_s : float or None
        Time (s since power-on) after which every sliding average stays inside the band,
        interpolated between the last average outside it and the next; the time of the
        first sample when none is outside; None when the last averages are outside, or
        the trend after ``reference_after_s`` still drifts by over half the band (the
        bias had not settled by the end of the record).
    average_noise_deg_h : float or None
        Standard deviation of the non-overlapping averages after ``reference_after_s``,
        deg/h: the noise of the trend. Above a fifth of the band, noise alone can carry the
        trend out of the band and the warm-up time comes out late (widen the average).
    """

    t_s: NDArray[np.float64]
    bias_deg_h: NDArray[np.float64]
    reference_deg_h: float
    band_deg_h: float
    average_s: float
    warmup_time_s: float | None
    average_noise_deg_h: float | None = None


def sliding_means(x: NDArray[np.float64], window: int, step: int
                  ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """(start index, mean) of every ``window``-sample stretch of ``x`` starting at
    multiples of ``step``; NaN samples are left out and a stretch with less than half its
    samples finite has a NaN mean."""
    finite = np.isfinite(x)
    csum = np.concatenate([[0.0], np.cumsum(np.where(finite, x, 0.0))])
    ccount = np.concatenate([[0], np.cumsum(finite)])
    starts = np.arange(0, len(x) - window + 1, step, dtype=np.int64)
    total = csum[starts + window] - csum[starts]
    count = ccount[starts + window] - ccount[starts]
    with np.errstate(invalid="ignore", divide="ignore"):
        means = np.where(count >= window / 2, total / np.maximum(count, 1), np.nan)
    return starts, means


def warmup_curve(rate_deg_s: ArrayLike, sample_rate_hz: float, *, first_s: float,
                 band_deg_h: float, average_s: float, reference_after_s: float | None = None
                 ) -> WarmupCurve:
    """Bias trend of a cycle and the time its bias enters a band about the settled bias.

    The trend is the mean over a window of ``average_s`` slid by a quarter window; the
    settled bias is the mean after ``reference_after_s`` (default: the second half of the
    record). The warm-up time is when the trend enters the band ``+- band_deg_h`` for good;
    a trend that still drifts by over half the band across that stretch has not settled.
    Choose ``average_s`` so that the averages' noise (the Allan deviation at that tau)
    is well inside the band, else noise alone keeps the trend leaving it.

    Parameters
    ----------
    rate_deg_s : array_like, shape (n,)
        One axis of the cycle's record, deg/s, on its sample grid (NaN where missing).
    sample_rate_hz : float
        Sample rate, Hz.
    first_s : float
        Time of the first sample, s since power-on (the turn-on time).
    band_deg_h : float
        Half width of the band, deg/h.
    average_s : float
        Length of each average, s.
    reference_after_s : float, optional
        Start of the stretch whose mean is the settled bias, s since power-on.

    Returns
    -------
    WarmupCurve

    Raises
    ------
    TooFewSamplesError
        Fewer than four windows of ``average_s`` in the record, or nothing after
        ``reference_after_s``.
    ValueError
        A band or average that is not a positive number.
    """
    x = _rate_1d(rate_deg_s)
    fs = check_sample_rate(sample_rate_hz)
    band = _positive("band_deg_h", band_deg_h)
    window = max(1, int(round(_positive("average_s", average_s) * fs)))
    if len(x) < 4 * window:
        raise TooFewSamplesError(f"the record holds {len(x) / fs:.4g} s, fewer than four "
                                 f"averages of {window / fs:g} s: shorten the average or "
                                 f"record longer")
    t_end = first_s + len(x) / fs
    after = first_s + (t_end - first_s) / 2 if reference_after_s is None else reference_after_s
    reference = cycle_bias(x, fs, first_s=first_s, after_s=after).mean_deg_h
    starts, means = sliding_means(x, window, max(1, window // 4))
    centres = np.asarray(first_s + (starts + window / 2.0) / fs, dtype=np.float64)
    bias = np.asarray(means * S_PER_H, dtype=np.float64)
    off = np.abs(bias - reference)
    outside = np.flatnonzero(off > band)  # a NaN average (a gap) is neither in nor out
    finite = np.flatnonzero(np.isfinite(off))
    tail = finite[centres[finite] >= after]
    drift = 0.0
    if tail.size >= 3:
        slope = np.polyfit(centres[tail], bias[tail], 1)[0]
        drift = abs(slope) * float(centres[tail[-1]] - centres[tail[0]])
    if finite.size == 0 or drift > band / 2.0:
        settled: float | None = None
    elif outside.size == 0:
        # in the band from the first average on; missing data before it leave only that
        settled = float(first_s) if finite[0] == 0 else float(centres[finite[0]])
    elif outside[-1] == len(bias) - 1:
        settled = None
    else:
        settled = _refined_crossing(centres, off, int(outside[-1]), band, window / fs)
    _, blocks = sliding_means(x[int(max(0.0, (after - first_s) * fs)):], window, window)
    blocks = blocks[np.isfinite(blocks)]
    noise = float(blocks.std(ddof=1)) * S_PER_H if blocks.size >= 3 else None
    return WarmupCurve(centres, bias, reference, band, window / fs, settled, noise)


def _refined_crossing(t: NDArray[np.float64], off: NDArray[np.float64], last_out: int,
                      band: float, average_s: float) -> float:
    """Where ``off`` (the trend's distance from the settled bias) falls through ``band``
    for good, near the averages ``last_out`` (outside) and ``last_out + 1`` (inside).

    The last average outside the band is the latest of many noisy chances, so it comes
    late. A warm-up decays about exponentially, so ``log(off)`` is about a straight line
    through the crossing: fitted to the averages of the last descent through the band
    whose distance lies between half the band and three times it, it crosses the band
    where the noise-free trend does, to the noise of the averages it spans. An average of
    ``w`` seconds of ``exp(-t / tau)`` is ``sinh(x) / x`` (``x = w / 2 tau``) times its
    value at its centre, which moves the crossing ``tau ln(sinh(x) / x)`` late: taken
    off, with ``tau`` from the fitted slope. The coarse crossing (interpolated between the
    two averages) is kept when fewer than four averages qualify or the fit does not
    descend.
    """
    i = last_out
    coarse = float(t[i + 1])
    if np.isfinite(off[i + 1]) and off[i] > off[i + 1]:
        coarse = float(t[i] + (off[i] - band) / (off[i] - off[i + 1]) * (t[i + 1] - t[i]))
    # the last descent: from the last average above three bands, to the first below half
    above = np.flatnonzero(off[:i + 1] > 3.0 * band)
    lo = int(above[-1]) if above.size else 0
    below = np.flatnonzero(off[i + 1:] < 0.5 * band)
    hi = i + 1 + (int(below[0]) if below.size else len(off) - i - 2)
    sel = np.arange(lo, hi + 1)
    sel = sel[np.isfinite(off[sel]) & (off[sel] >= 0.5 * band) & (off[sel] <= 3.0 * band)]
    if sel.size < 4:
        return coarse
    slope, intercept = np.polyfit(t[sel], np.log(off[sel]), 1)
    if not slope < 0:
        return coarse
    tau = -1.0 / slope
    x = average_s / (2.0 * tau)
    smear = tau * math.log(math.sinh(x) / x) if 1e-6 < x < 50 else 0.0
    return float((math.log(band) - intercept) / slope) - smear


@dataclass(frozen=True)
class Repeatability:
    """Turn-on to turn-on bias repeatability: the spread of the per-cycle mean biases.

    Attributes
    ----------
    value_deg_h : float or None
        Standard deviation (ddof = 1) of the per-cycle mean biases, deg/h (None with fewer
        than two cycles).
    ci_low_deg_h, ci_high_deg_h : float or None
        Its chi-square interval with ``n_cycles - 1`` degrees of freedom.
    n_cycles : int
        Cycles with a mean bias.
    mean_deg_h : float or None
        Mean of the per-cycle biases, deg/h.
    within_cycle_deg_h : float or None
        Root mean square of the cycles' own standard errors, deg/h: the part of the
        spread the noise inside each cycle explains (the repeatability includes it).
    confidence : float
        Two-sided level of the interval.
    """

    value_deg_h: float | None
    ci_low_deg_h: float | None
    ci_high_deg_h: float | None
    n_cycles: int
    mean_deg_h: float | None
    within_cycle_deg_h: float | None
    confidence: float


def turn_on_repeatability(biases: list[CycleBias] | tuple[CycleBias, ...],
                          confidence: float = 0.95) -> Repeatability:
    """Turn-on to turn-on bias repeatability of a sequence of power cycles.

    Parameters
    ----------
    biases : sequence of CycleBias
        Each cycle's mean bias after its warm-up (:func:`cycle_bias`).
    confidence : float
        Two-sided level of the chi-square interval.

    Returns
    -------
    Repeatability

    References
    ----------
    IEEE Std 952-1997 and IEEE Std 1431-2004, the turn-on to turn-on bias repeatability
    test (drift rate repeatability): the standard deviation of the biases measured after
    each of N turn-ons, each after the specified warm-up.
    """
    summary: CycleSummary = summarize_cycles([b.mean_deg_h for b in biases], confidence)
    errs = [b.stderr_deg_h for b in biases if b.stderr_deg_h is not None]
    within = float(math.sqrt(np.mean(np.square(errs)))) if errs else None
    return Repeatability(summary.std, summary.std_low, summary.std_high, summary.n,
                         summary.mean, within, confidence)
