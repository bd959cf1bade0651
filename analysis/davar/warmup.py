"""What a DAVAR tells a test engineer: when the gyro has warmed up, and whether the run is
stationary.

The warm-up ends at the start of the first window whose Allan curve stays inside the
confidence band of the later ones: window ``j`` is *settled* when, at every tau, its
chi-square interval overlaps the interval of the pooled Allan variance of all later
windows (their mean, with the edf of the overlapping estimator over the span they
cover). The warm-up end is the start of the first window from which every window is
settled. The run is *stationary* when that is the first window: no warm-up and no later
change of the Allan curve.

The intervals are taken at a wide level (0.9999 by default): a run has tens of windows
and taus, and the test must stay quiet on stationary data (the tests hold the false
warm-up rate under 5 % of seeds). Windows near the end are compared with few later ones,
whose band is wide: a change within the last two window lengths is hard to see, and a
run whose settled stretch is shorter than that gets no warm-up end at all.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from analysis.allan.estimators import chi2_interval, overlapping_edf
from analysis.davar.estimators import DavarResult


@dataclass(frozen=True)
class WarmupVerdict:
    """Warm-up time and stationarity of one axis of a DAVAR.

    Attributes
    ----------
    warmup_end_s : float or None
        Start time in s (from the record start) of the first window after which every
        window's Allan curve stays inside the band of the later ones; ``0.0`` when the run
        has no warm-up, ``None`` when the settled stretch before the end of the record
        holds less than two window lengths of data (the curve is still changing).
    stationary : bool
        True when every window is settled (``warmup_end_s == 0.0``).
    window_start_s : ndarray, shape (n_judged,)
        Start times in s of the windows judged (about ten per window length, and the last).
    settled : ndarray of bool, shape (n_judged,)
        Per judged window: its curve lies inside the band of the later windows at every tau.
    excess : ndarray, shape (n_judged,)
        Per window, the largest gap at any tau between its interval and the band of the
        later ones, as a log10 ratio of Allan variances (0 when settled).
    confidence : float
        Two-sided level of the intervals compared.
    """

    warmup_end_s: float | None
    stationary: bool
    window_start_s: NDArray[np.float64]
    settled: NDArray[np.bool_]
    excess: NDArray[np.float64]
    confidence: float


def _band_factors(
    spans: NDArray[np.int64],
    m: NDArray[np.int64],
    alpha: NDArray[np.int64],
    confidence: float,
    *,
    points: int = 4,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Chi-square interval factors (low, high), each (n_spans, n_tau), of overlapping Allan
    variances over records of ``spans`` samples.

    Computed exactly at a few log-spaced spans and interpolated in log-log between them
    (edf and interval are smooth in the record length; the exact edf costs milliseconds).
    """
    grid = np.unique(np.geomspace(spans.min(), spans.max(), points).round().astype(np.int64))
    edf = np.stack([overlapping_edf(int(n), m, alpha) for n in grid])  # (n_grid, n_tau)
    low, high = chi2_interval(np.ones_like(edf), edf, confidence)
    if len(grid) == 1:
        return (np.broadcast_to(low[0], (len(spans), len(m))),
                np.broadcast_to(high[0], (len(spans), len(m))))
    x, xg = np.log(spans.astype(float)), np.log(grid.astype(float))

    def interp(table: NDArray[np.float64]) -> NDArray[np.float64]:
        logs = np.log(table)
        stacked = np.stack([np.interp(x, xg, logs[:, i]) for i in range(len(m))], axis=1)
        return np.asarray(np.exp(stacked), dtype=np.float64)

    return interp(low), interp(high)


def detect_warmup(
    result: DavarResult, *, axis: int = 0, confidence: float = 0.9999
) -> WarmupVerdict:
    """Warm-up end and stationarity verdict of one axis of a DAVAR.

    Parameters
    ----------
    result : DavarResult
        Dynamic Allan variance of the run (any window and step).
    axis : int
        Gyro axis to judge.
    confidence : float
        Two-sided level of each window's and each band's chi-square interval.

    Returns
    -------
    WarmupVerdict

    Raises
    ------
    ValueError
        If ``confidence`` is not in (0, 1).
    """
    one = result.axis(axis)
    starts = np.round(one.window_start_s * one.sample_rate_hz).astype(np.int64)
    # Judge about ten windows per window length: finer steps add no information.
    stride = max(1, one.window_samples // 10 // one.step_samples)
    judged = np.unique(np.r_[np.arange(0, len(starts), stride), len(starts) - 1])
    # Windows across a recorded gap (NaN, see DAVAR's missing="gap") are neither judged
    # nor pooled.
    whole = np.asarray(np.isfinite(one.avar).all(axis=1), dtype=bool)
    judged = judged[whole[judged]]
    if judged.size == 0:
        return WarmupVerdict(warmup_end_s=None, stationary=False, window_start_s=np.zeros(0),
                             settled=np.zeros(0, dtype=bool), excess=np.zeros(0),
                             confidence=confidence)
    avar, m = one.avar[judged], one.m
    win_low, win_high = chi2_interval(avar, one.edf[judged], confidence)
    # Pooled curve of the (whole) windows after each judged one: a reverse running mean.
    later_sum = np.cumsum(np.where(whole[:, None], one.avar, 0.0)[::-1], axis=0)[::-1]
    later_count = np.cumsum(whole[::-1])[::-1]
    n_later = np.where(
        judged + 1 < len(starts), later_count[np.minimum(judged + 1, len(starts) - 1)], 0
    )
    band = np.where(
        n_later[:, None] > 0,
        later_sum[np.minimum(judged + 1, len(starts) - 1)] / np.maximum(n_later, 1)[:, None],
        avar,
    )
    spans = np.where(n_later > 0, one.n_samples - starts[np.minimum(judged + 1, len(starts) - 1)],
                     one.window_samples)
    low_f, high_f = _band_factors(spans, m, one.noise_alpha, confidence)
    band_low, band_high = band * low_f, band * high_f
    tiny = np.finfo(float).tiny
    gap = np.maximum(np.log10(np.maximum(band_low, tiny) / np.maximum(win_high, tiny)),
                     np.log10(np.maximum(win_low, tiny) / np.maximum(band_high, tiny)))
    excess = np.where(n_later > 0, np.maximum(gap, 0.0).max(axis=1), 0.0)
    settled = excess == 0.0
    unsettled = np.flatnonzero(~settled)
    first = 0 if unsettled.size == 0 else int(unsettled[-1]) + 1
    window_start_s = starts[judged] / one.sample_rate_hz
    if first == 0:
        end: float | None = 0.0
    elif first < len(judged) and starts[-1] - starts[judged[first]] >= one.window_samples:
        end = float(window_start_s[first])
    else:
        end = None
    return WarmupVerdict(warmup_end_s=end, stationary=first == 0, window_start_s=window_start_s,
                         settled=settled, excess=excess, confidence=confidence)
