"""IEEE 952 read-offs of the Allan deviation, each with the interval of the values it came from.

**Angle random walk** (IEEE Std 952-1997, Annex C): the value at tau = 1 h of the -1/2
line through the white-rate region, equivalently ``sigma(tau) sqrt(tau)`` on that line.
The region is the stretch of taus where the *fitted* white-rate term dominates the Allan
variance (at least :data:`WHITE_DOMINANCE` of the fitted model) and the measured local
slope is within :data:`ARW_SLOPE_TOLERANCE` of -1/2, outside the tau zones where the
five-term model does not hold (tones, an output filter: :mod:`analysis.figures.zones`). Among
such stretches the one spanning the most octaves is read. Quantization (a -1 slope, the
fitted Q term) and a random walk or flicker floor fail the dominance test; a tone's
bump or a filter's dip fail the zone test; two taus on the falling edge of a bump whose
slope happens to pass -1/2 cannot make a region. Without a fitted white-rate term the
region is chosen by the slope alone, and the note says so.

**The white-noise bound.** The Allan variance of independent noises is the sum of theirs,
and white rate noise of coefficient ``N`` contributes ``N^2 / tau`` at every tau past the
output filter. So ``N`` is at most the least ``sigma(tau) sqrt(tau)`` of the curve outside
an output filter's taus (:func:`white_noise_bound`; tones and quantization only add). A
-1/2 stretch whose level is above that bound beyond both intervals (at
:data:`WHITE_BOUND_CONFIDENCE`) and the slack of a -1/2 line (:data:`WHITE_BOUND_SLACK`)
is not white noise: on a MEMS accelerometer whose short
taus are all tone or filter zones and whose fit holds no white term, the falling edge of
a bump at 700-3000 s passes the slope test and read 30 m/s/sqrt(h) where the curve at
10 ms shows 0.2. Such a stretch is passed over; where none is left, the value is the
bound itself, marked as an upper bound (:attr:`ReadOff.upper_bound`; its interval runs
from 0).

**Bias instability**: ``sigma_min / 0.664`` (IEEE Std 952-1997, Annex C: the flicker
floor of the Allan deviation is ``sqrt(2 ln 2 / pi) B = 0.664 B``), where ``sigma_min`` is
the minimum of a smoothed curve, not of the raw points: a raw minimum over noisy values
is biased low, more so with long taus whose values rest on a few clusters. The curve is
smoothed by a local quadratic fit of ``log avar`` against ``log tau`` (a Gaussian kernel
one octave wide; a quadratic follows the curvature at a minimum without bias), each value
weighted by its precision, ``edf / 2`` (the inverse variance of the log of a chi-square
estimate) times its share of an octave of tau, and corrected for the mean of the log of a
chi-square variable (``psi(edf/2) - log(edf/2)``). Noisy long-tau values thus count for
what they hold, and the minimum is read where the smoothed curve is lowest. When that is
the longest tau (the curve has not turned: an upper bound), the value there is a local
line instead, whose variance at a boundary is several times lower (Fan and Gijbels,
"Local polynomial modelling and its applications", 1996, sec. 3.2: odd degrees).

**Intervals.** Each read-off carries the equivalent degrees of freedom of the variance it
was read from: ``sum_i s_i edf_i`` over the ARW region (``s_i`` the octave share: values
on a dense grid are strongly correlated, so each octave counts about once), at least the
largest single ``edf_i``; for the smoothed minimum ``2 / var(log avar_hat)`` from the
local fit's equivalent kernel. :meth:`ReadOff.interval` turns it into a chi-square interval
at any confidence level.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from analysis.allan.confidence import ONE_SIGMA, chi2_interval, local_noise_alpha
from analysis.allan.estimators import AllanResult
from analysis.allan.gaps import valid_stretches
from analysis.figures.zones import TauZone, outside_zones
from analysis.fit.least_squares import NoiseCoefficients, log_tau_share
from analysis.units.conversions import S_PER_H

#: Local log-log slope of the Allan deviation accepted as "the -1/2 line".
ARW_SLOPE_TOLERANCE = 0.15
#: Least share of the fitted model's Allan variance the white-rate term has in the ARW region.
WHITE_DOMINANCE = 0.95
#: Confidence at which a -1/2 stretch's level is tested against :func:`white_noise_bound`.
WHITE_BOUND_CONFIDENCE = 0.99
#: How far above the white-noise bound a -1/2 stretch's level may lie and still be read: a
#: stretch's local slopes may stray :data:`ARW_SLOPE_TOLERANCE` from -1/2, so its level
#: drifts by up to ``2^0.15`` an octave; two octaves of it are allowed.
WHITE_BOUND_SLACK = 2.0 ** (2 * ARW_SLOPE_TOLERANCE)
#: sqrt(2 ln 2 / pi): the Allan deviation of flicker rate noise over its coefficient B.
BIAS_INSTABILITY_FACTOR = 0.664
#: Width (standard deviation, octaves) of the Gaussian kernel smoothing the curve's minimum.
SMOOTHING_OCTAVES = 1.0
#: Correlation of the log Allan variances at two taus, ``(tau_short / tau_long)^gamma``, by
#: the rate-noise exponent alpha seen there (the smaller gamma of the two is used).
#: Measured (overlapping estimator, 2^15 samples, 300 runs, octave taus): white rate
#: 0.51 / 0.19 / 0.09 one, two, three octaves apart; flicker rate 0.67 / 0.30 / 0.14;
#: random walk 0.88 / 0.66 / 0.48. Unknown noise types take the smallest gamma.
CORRELATION_EXPONENT = {2: 1.0, 0: 1.0, -1: 0.7, -2: 0.3}
#: Most taus at which the smoothed curve is evaluated in one pass (longer grids are thinned).
MAX_CANDIDATES = 400
#: Log-tau bins per octave in which values are taken as fully correlated (long grids).
CORRELATION_BINS_PER_OCTAVE = 16


@dataclass(frozen=True)
class ReadOff:
    """A figure read off the Allan deviation curve.

    Attributes
    ----------
    value : float or None
        The figure in its unit (deg/sqrt(h) for ARW, deg/h for bias instability).
    tau_low_s, tau_high_s : float or None
        The tau range it was read from, s (one tau for the minimum).
    note : str
        What the reader should know (a fallback, an upper bound), or "".
    edf : float or None
        Equivalent degrees of freedom of the Allan variance behind the value.
    upper_bound : bool
        The value bounds the figure from above and does not measure it (the white-noise
        bound where the curve shows no -1/2 stretch): its interval runs from 0.
    """

    value: float | None
    tau_low_s: float | None
    tau_high_s: float | None
    note: str = ""
    edf: float | None = None
    upper_bound: bool = False

    def interval(self, confidence: float = ONE_SIGMA) -> tuple[float | None, float | None]:
        """Two-sided chi-square interval of the value at ``confidence`` (None, None if unknown).

        The value is a deviation (the root of an Allan variance with ``edf`` degrees of
        freedom), so its bounds are ``value sqrt(edf / chi2_quantile)``; an upper bound's
        interval is ``[0, high]``.
        """
        if self.value is None or self.edf is None:
            return None, None
        low, high = chi2_interval(1.0, self.edf, confidence)
        return (0.0 if self.upper_bound else self.value * math.sqrt(float(low)),
                self.value * math.sqrt(float(high)))

    def log_sd(self) -> float | None:
        """Standard deviation of ``log(value)`` (``1 / sqrt(2 edf)``), None if unknown."""
        return None if self.edf is None else 1.0 / math.sqrt(2.0 * self.edf)


def correlated_log_variance(coef: NDArray[np.float64], result: AllanResult) -> float:
    """Variance of ``sum_i coef_i log avar_i`` with correlated Allan values.

    ``var(log avar_i) = 2 / edf_i``; the correlation of two values is
    ``(tau_i / tau_j)^gamma`` (:data:`CORRELATION_EXPONENT`). Values within a
    1/:data:`CORRELATION_BINS_PER_OCTAVE` octave are summed as fully correlated first, so
    an every-m grid of tens of thousands of taus costs no more than a log grid.
    """
    tau = result.tau_s
    sd = np.sqrt(2.0 / np.asarray(result.edf, dtype=float))
    alpha = local_noise_alpha(result.m, np.asarray(result.avar), result.n_samples)
    gamma = np.array(
        [CORRELATION_EXPONENT.get(int(a), min(CORRELATION_EXPONENT.values())) for a in alpha]
    )
    used = coef != 0
    logt = np.log2(tau[used])
    bins = np.floor((logt - logt.min()) * CORRELATION_BINS_PER_OCTAVE).astype(np.int64)
    _, inverse = np.unique(bins, return_inverse=True)
    size = int(inverse.max()) + 1
    amount = np.bincount(inverse, weights=(coef * sd)[used], minlength=size)
    centre = np.bincount(inverse, weights=logt, minlength=size) / np.bincount(
        inverse, minlength=size
    )
    g = np.full(size, np.inf)
    np.minimum.at(g, inverse, gamma[used])
    distance = np.abs(centre[:, None] - centre[None, :])  # octaves apart
    rho = 2.0 ** (-distance * np.minimum(g[:, None], g[None, :]))
    return float(amount @ rho @ amount)


def local_adev_slope(tau_s: NDArray[np.float64], adev: NDArray[np.float64]) -> NDArray[np.float64]:
    """Log-log slope of the Allan deviation at each tau, over about an octave either side."""
    logt, loga = np.log(tau_s), np.log(adev)
    if len(logt) < 2:
        return np.full(len(logt), np.nan)
    lo = np.maximum(logt - math.log(2), logt[0])
    hi = np.minimum(logt + math.log(2), logt[-1])
    rise = np.interp(hi, logt, loga) - np.interp(lo, logt, loga)
    return np.asarray(rise / np.where(hi > lo, hi - lo, 1.0), dtype=np.float64)


def white_share(result: AllanResult, fit: NoiseCoefficients | None) -> NDArray[np.float64] | None:
    """Share of the fitted model's Allan variance that its white-rate term holds, per tau.

    None when the fit has no positive white-rate term.
    """
    if fit is None or not fit.values.get("N"):
        return None
    model = fit.model_avar(result.tau_s)
    return np.where(
        model > 0, fit.term_avar("N", result.tau_s) / np.where(model > 0, model, 1.0), 0.0
    )


def white_noise_bound(result: AllanResult, zones: Sequence[TauZone] = ()) -> ReadOff | None:
    """The least ``sigma(tau) sqrt(tau)`` of a 1-D Allan curve outside an output filter's
    taus, as an angle random walk (deg/sqrt(h)) marked :attr:`ReadOff.upper_bound`: white
    rate noise adds ``N^2 / tau`` to the Allan variance wherever the filter has not taken
    it off, so ``N`` is at most this (the module docstring). None: no tau outside a filter.
    Tone zones count (a tone only adds)."""
    tau = result.tau_s
    usable = outside_zones(tau, [z for z in zones if z.kind == "output filter"])
    level = np.sqrt(np.asarray(result.avar, dtype=float) * tau)
    usable &= np.isfinite(level) & (level > 0)
    if not usable.any():
        return None
    i = int(np.flatnonzero(usable)[np.argmin(level[usable])])
    return ReadOff(float(level[i]) * math.sqrt(S_PER_H), float(tau[i]), float(tau[i]),
                   f"upper bound: the least sigma sqrt(tau), at tau {tau[i]:.3g} s (white "
                   f"noise would put the curve at least this high there)",
                   float(np.asarray(result.edf, dtype=float)[i]), upper_bound=True)


def _above_bound(read: ReadOff, bound: ReadOff | None) -> bool:
    """Whether ``read``'s level is above ``bound`` beyond both their intervals and
    :data:`WHITE_BOUND_SLACK`."""
    if bound is None or read.value is None:
        return False
    low, _ = read.interval(WHITE_BOUND_CONFIDENCE)
    _, high = replace(bound, upper_bound=False).interval(WHITE_BOUND_CONFIDENCE)
    return low is not None and high is not None and low > high * WHITE_BOUND_SLACK


def _line_readoff(result: AllanResult, region: NDArray[np.bool_], note: str) -> ReadOff:
    """The -1/2 line over ``region`` (edf-and-octave weighted geometric mean of
    ``sigma sqrt(tau)``) read at tau = 1 h, with the region's taus and edf."""
    tau = result.tau_s
    weights = np.where(region, log_tau_share(tau) * np.asarray(result.edf, dtype=float), 0.0)
    log_n = float(np.average(np.log(np.sqrt(result.avar * tau)), weights=weights))
    value = math.exp(log_n) * math.sqrt(S_PER_H)  # deg/s*sqrt(s) = deg/sqrt(s) -> deg/sqrt(h)
    dof = 2.0 / correlated_log_variance(weights / weights.sum(), result)
    return ReadOff(value, float(tau[region][0]), float(tau[region][-1]), note, dof)


def arw_readoff(result: AllanResult, fit: NoiseCoefficients | None = None, *,
                zones: Sequence[TauZone] = ()) -> ReadOff:
    """Angle random walk (deg/sqrt(h)) read off the white-rate region of a 1-D Allan curve.

    Parameters
    ----------
    result : AllanResult
        One axis' Allan variance in (deg/s)^2.
    fit : NoiseCoefficients, optional
        The axis' five-term fit: its white-rate term decides the region (see the module
        docstring). Without it (or without a positive N) the slope alone does.
    zones : sequence of TauZone
        Tau ranges not to read in (tones, an output filter).

    Returns
    -------
    ReadOff
        The -1/2 line fitted over the region (edf-and-octave weighted geometric mean of
        ``sigma sqrt(tau)``), read at tau = 1 h, with the region's taus and edf; a region
        above the white-noise bound is passed over, and where no region is left the
        value is that bound (:func:`white_noise_bound`, an upper bound).
    """
    tau, adev = result.tau_s, np.sqrt(result.avar)
    edf = np.asarray(result.edf, dtype=float)
    slope = local_adev_slope(tau, adev)
    allowed = outside_zones(tau, zones)
    on_line = allowed & (np.abs(slope + 0.5) <= ARW_SLOPE_TOLERANCE)
    share = white_share(result, fit)
    notes = []
    if share is None:
        region = on_line
        if fit is not None:
            notes.append("the fit has no white-rate term: region chosen by the slope alone")
    else:
        region = on_line & (share >= WHITE_DOMINANCE)
    bound = white_noise_bound(result, zones)
    octaves = log_tau_share(tau)
    stretches = sorted(zip(*valid_stretches(region), strict=True),
                       key=lambda s: (octaves[s[0]:s[1]].sum(), edf[s[0]:s[1]].sum()),
                       reverse=True)
    for start, stop in stretches:
        mask = np.zeros(len(tau), dtype=bool)
        mask[start:stop] = True
        read = _line_readoff(result, mask, "; ".join(notes))
        if not _above_bound(read, bound):
            return read
        notes.append(_passed_over(read, bound))
    pool = allowed if allowed.any() else np.ones(len(tau), dtype=bool)
    score = np.where(pool, np.abs(slope + 0.5) if share is None else -share, np.inf)
    i = int(np.nanargmin(score))
    what = (f"white rate at most {share[i]:.0%} of the fitted curve" if share is not None
            else f"nearest slope {slope[i]:.2f}")
    notes.append(f"no -1/2 region where white rate dominates; read at tau {tau[i]:.3g} s ({what})")
    region = np.zeros(len(tau), dtype=bool)
    region[i] = True
    read = _line_readoff(result, region, "; ".join(notes))
    if bound is not None and _above_bound(read, bound):
        notes.append(_passed_over(read, bound))
        return replace(bound, note="; ".join([*notes, bound.note]))
    return read


def _passed_over(read: ReadOff, bound: ReadOff | None) -> str:
    """The note of a reading passed over for being above the white-noise bound."""
    assert bound is not None and read.value is not None
    return (f"the -1/2 reading {read.value:.3g} at tau {read.tau_low_s:.3g}-"
            f"{read.tau_high_s:.3g} s is above what the curve allows white noise "
            f"({bound.value:.3g} at tau {bound.tau_low_s:.3g} s): not white noise, passed over")


def smoothed_log_avar(result: AllanResult, *, octaves: float = SMOOTHING_OCTAVES, degree: int = 2,
                      at: NDArray[np.int64] | None = None, with_variance: bool = True,
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Local polynomial smooth of ``log avar`` at every tau (or at indices ``at``) and its variance.

    Weighted least squares of a polynomial of ``degree`` in ``log tau`` around each tau
    with weights ``K_i p_i``: ``K`` a Gaussian kernel of ``octaves`` standard deviation in
    log tau, ``p_i = s_i edf_i / 2`` the value's precision per octave (see the module
    docstring). The variance of the smoothed value is that of ``sum_i l_i log a_i`` over
    its equivalent kernel ``l`` (:func:`correlated_log_variance`; NaN unless
    ``with_variance``). A grid of more than :data:`MAX_CANDIDATES` taus (every m) is first
    pooled into 1/:data:`CORRELATION_BINS_PER_OCTAVE`-octave bins (precision-weighted
    means), far finer than the kernel, so the cost does not grow with the grid.
    """
    from scipy import special
    x = np.log(result.tau_s)
    edf = np.asarray(result.edf, dtype=float)
    y = np.log(result.avar) - (special.digamma(edf / 2.0) - np.log(edf / 2.0))
    precision = log_tau_share(result.tau_s) * edf / 2.0
    if len(x) > MAX_CANDIDATES:
        logt = np.log2(result.tau_s)
        member = np.unique(
            np.floor((logt - logt[0]) * CORRELATION_BINS_PER_OCTAVE), return_inverse=True
        )[1]
        pooled = np.bincount(member, weights=precision)
        bx = np.bincount(member, weights=precision * x) / pooled
        by = np.bincount(member, weights=precision * y) / pooled
        share = precision / pooled[member]  # each value's part of its bin's mean
    else:
        member, pooled, bx, by, share = np.arange(len(x)), precision, x, y, np.ones(len(x))
    h = octaves * math.log(2.0)
    points = np.arange(len(x)) if at is None else np.asarray(at)
    smooth, var = np.empty(len(points)), np.empty(len(points))
    for k, j in enumerate(points):
        d = bx - x[j]
        w = pooled * np.exp(-0.5 * (d / h) ** 2)
        design = np.column_stack([d**p for p in range(min(degree + 1, len(bx)))])
        gram = design.T @ (design * w[:, None])
        kernel = np.linalg.pinv(gram)[0] @ (design * w[:, None]).T  # equivalent kernel on the bins
        smooth[k] = float(kernel @ by)
        var[k] = (
            correlated_log_variance(kernel[member] * share, result) if with_variance else math.nan
        )
    return smooth, var


def bias_instability_readoff(result: AllanResult, *, zones: Sequence[TauZone] = ()) -> ReadOff:
    """Bias instability (deg/h): the smoothed curve's minimum / 0.664 (IEEE 952 Annex C).

    See the module docstring for the smoothing. When the minimum is at the longest tau
    the curve had not turned yet: the value is then an upper bound and the note says so.
    Taus inside ``zones`` (tones, an output filter) are not candidates for the minimum.
    """
    tau = result.tau_s
    allowed = outside_zones(tau, zones)
    if not allowed.any():
        allowed = np.ones(len(tau), dtype=bool)
    candidates = np.flatnonzero(allowed)
    if (
        len(candidates) > MAX_CANDIDATES
    ):  # an every-m grid: a log-spaced subset, then its neighbours
        picks = np.unique(np.geomspace(1, len(candidates), MAX_CANDIDATES).astype(int) - 1)
        smooth, _ = smoothed_log_avar(result, at=candidates[picks], with_variance=False)
        best = int(picks[int(np.argmin(smooth))])
        candidates = candidates[max(best - 2 * len(candidates) // MAX_CANDIDATES, 0):
                                best + 2 * len(candidates) // MAX_CANDIDATES + 1]
    smooth, _ = smoothed_log_avar(result, at=candidates, with_variance=False)
    j = int(candidates[int(np.argmin(smooth))])
    note = ""
    degree = 2
    if j == len(tau) - 1:
        note = "minimum at the longest tau: upper bound, record longer"
        # the curve has not turned: no curvature to follow, and a local line is the
        # boundary smoother of lower variance (odd degrees keep their interior bias at an edge)
        degree = 1
    level, var = smoothed_log_avar(result, degree=degree, at=np.array([j]))
    sigma_min = math.exp(level[0] / 2.0)
    value = sigma_min / BIAS_INSTABILITY_FACTOR * S_PER_H
    dof = 2.0 / max(float(var[0]), 1e-300)
    return ReadOff(value, float(tau[j]), float(tau[j]), note, dof)
