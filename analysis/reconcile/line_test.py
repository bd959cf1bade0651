"""Model versus measurement: a spectral line the Allan curve cannot see (the sinusoid's detector).

A sinusoid of amplitude ``A`` in white noise of variance ``sigma^2`` per sample adds
``A^2 / 2`` to the variance, spread by the Allan curve over a bump at taus of about half
its period: a line of a tenth of ``sigma`` moves no Allan value beyond its confidence
interval in an hour at 10 Hz. The periodogram of the whole record gathers the line's
power into one bin, ``N A^2 / 4`` over a background of ``sigma^2``: for ``N = 36000``
samples and ``A = 0.06 sigma``, 32 times the background. The Allan gap (G2 of
:mod:`analysis.reconcile.discrepancy`) is therefore the wrong detector for a faint line; this
module is the right one, and :mod:`analysis.reconcile` treats a line it finds as a
disagreement with the model as much as a significant gap.

**Spectrum.** The record (less its least-squares line) is transformed at full length,
zero-padded to twice its length, so that the ordinates sit every half bin and a line
between two bins loses at most ``1 - sinc^2(1/4)`` = 19 % of its power (a quarter-bin
offset) instead of 59 %. ``P_k = |X_k|^2 / N`` is, for Gaussian noise of smooth spectrum
``S``, ``S(f_k)`` times an Exp(1) variable.

**Background.** The running median of the integer-bin ordinates in a window symmetric
in frequency, ``[f (1 - w), f (1 + w)]`` (:func:`analysis.figures.tones.running_background`, the
median of a monotone spectrum across the window is its centre value), over ``ln 2`` (the
median of Exp(1)); between integer bins its logarithm is interpolated.

**Test.** The median of ``n`` Exp(1) ordinates has a relative variance ``1 / (n ln^2 2)``
= ``2.08 / n``, that of a mean of ``n / 2.08``; so the background is taken as a
``chi2(nu_b) / nu_b`` variable with ``nu_b = 2 n / 2.08`` and ``R = P / B`` as
``F(2, nu_b)``, whose survival is ``(1 + 2 R / nu_b)^(-nu_b / 2)`` (L1). A line is
detected when the smallest p-value times the number of ordinates tested (both the
integer and the half bins: Bonferroni, conservative for the correlated half bins) is
below ``alpha`` (L2). Tested are the frequencies of at least ``min_cycles`` periods in
the record whose background window holds at least ``2 MIN_HALF_WINDOW + 1`` integer
bins. Under the model (Gaussian noise of smooth spectrum: white, flicker, random walk,
Gauss-Markov) the test names a line in at most ``alpha`` of the records.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from analysis.figures.tones import running_background

#: Family-wise false-alarm level of the line test over every ordinate tested (L2).
LINE_ALPHA = 1e-3
#: Ordinates per bin of the zero-padded transform.
OVERSAMPLE = 2
#: Relative variance of the median of n Exp(1) variables, times n (``1 / ln^2 2``).
MEDIAN_VARIANCE = 1.0 / math.log(2.0) ** 2


@dataclass(frozen=True)
class LineDetection:
    """The strongest line of a record and its significance.

    Attributes
    ----------
    freq_hz : float
        Frequency of the strongest ordinate, Hz (within a quarter bin, ``1 / (4 T)``, of the
        line's).
    ratio : float
        Its power over the background (``R`` of L1).
    p_value : float
        Family-wise p-value: the ordinate's (L1) times the number tested (L2), at most 1.
    n_tested : int
        Ordinates tested.
    """

    freq_hz: float
    ratio: float
    p_value: float
    n_tested: int

    def significant(self, alpha: float = LINE_ALPHA) -> bool:
        """Whether the line is detected at family-wise level ``alpha``."""
        return self.p_value < alpha

    @property
    def statistic(self) -> str:
        """The test and its value, for the report."""
        return (f"spectral line at {1.0 / self.freq_hz:.4g} s, {self.ratio:.1f} x background, "
                f"p = {self.p_value:.2g} over {self.n_tested} frequencies")


def strongest_line(rate_deg_s: NDArray[np.float64], sample_rate_hz: float, *,
                   min_cycles: float) -> LineDetection | None:
    """The strongest spectral line of a 1-D rate record (deg/s) and its p-value (L1, L2).

    Parameters
    ----------
    rate_deg_s : ndarray, shape (N,)
        Rate samples, deg/s (finite).
    sample_rate_hz : float
        Sample rate, Hz.
    min_cycles : float
        Fewest periods in the record of a frequency tested.

    Returns
    -------
    LineDetection or None
        None when no frequency can be tested (a record too short).
    """
    x = np.asarray(rate_deg_s, dtype=np.float64)
    n = len(x)
    t = np.arange(n, dtype=np.float64)
    x = x - np.polyval(np.polyfit(t, x, 1), t)
    power = np.abs(np.fft.rfft(x, OVERSAMPLE * n)) ** 2 / n
    whole = power[::OVERSAMPLE]
    background, half = running_background(whole, 2.0)
    k = np.arange(len(power)) / OVERSAMPLE
    lowest = min_cycles
    tested_whole = (half > 0) & (np.arange(len(whole)) >= lowest)
    if not tested_whole.any():
        return None
    idx = np.flatnonzero(tested_whole)
    inside = (k >= idx[0]) & (k <= idx[-1])
    log_b = np.interp(k[inside], idx, np.log(background[idx]))
    half_at = np.interp(k[inside], idx, half[idx].astype(np.float64))
    ratio = power[inside] / np.exp(log_b)
    nu_b = 2.0 * (2.0 * half_at + 1.0) / MEDIAN_VARIANCE
    log_p = -0.5 * nu_b * np.log1p(2.0 * ratio / nu_b)
    best = int(np.argmin(log_p))
    n_tested = int(inside.sum())
    p = min(1.0, math.exp(float(log_p[best])) * n_tested)
    freq = float(k[inside][best]) * sample_rate_hz / n
    return LineDetection(freq_hz=freq, ratio=float(ratio[best]), p_value=p, n_tested=n_tested)


__all__ = ["LINE_ALPHA", "LineDetection", "strongest_line"]
