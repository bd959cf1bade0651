"""Process capability and control charts of a graded figure over many units.

Every limit of a gyro profile is an upper limit, and every graded figure is a magnitude
(noise densities, instabilities, ``|bias|``) with the natural bound 0, which is no
specification limit. So, as ISO 22514-2 and AIAG's SPC manual compute a one-sided
characteristic:

``Cpu = (USL - mean) / (3 s)``
    the index of an upper limit (``Cpl = (mean - LSL) / (3 s)`` of a lower one);
    ``Cpk = min(Cpu, Cpl)`` of the limits there are;
``Cp = (USL - LSL) / (6 s)``
    only where both limits are given (never against the natural bound 0): then
    ``Cpk <= Cp`` always;

``s`` is the sample standard deviation of all the values (ddof 1): units are tested one at
a time, there are no rational subgroups, so this is the long-term sigma and the indexes
are what AIAG calls Ppu/Ppk. The interval of Cpk is the standard normal approximation
(Bissell 1990; Montgomery, *Introduction to Statistical Quality Control*, 6th ed., eq.
8.23): ``Cpk +- z sqrt(1/(9n) + Cpk^2/(2(n-1)))``.

Noise figures are skewed (a variance estimate is chi-square), not normal, so beside the
normal index stands ISO 22514-4's percentile method: a lognormal and a gamma distribution
(location 0) are fitted by maximum likelihood, the one with the larger likelihood kept,
and ``Cpu = (USL - X50) / (X99.865 - X50)`` (``Cpl = (X50 - LSL) / (X50 - X0.135)``,
``Cp = (USL - LSL) / (X99.865 - X0.135)``) with ``X_p`` its percentiles. Its interval is a
percentile bootstrap of :data:`BOOTSTRAP_RESAMPLES` resamples drawn with the fixed seed
:data:`BOOTSTRAP_SEED` (the same values give the same interval), the distribution family
kept for each resample.

The control chart is Shewhart's individuals chart (Montgomery, sec. 6.4): centre line the
mean, limits ``mean +- 3 MR/d2`` with ``MR`` the mean moving range of consecutive values
in test order and ``d2 = 1.128`` (n = 2); a value beyond a limit is out of control (rule 1
of the Western Electric rules).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special, stats

#: d2 of a moving range of two consecutive values (Montgomery, Appendix table VI).
D2_MOVING_RANGE = 1.128


@dataclass(frozen=True)
class FittedCapability:
    """ISO 22514-4 percentile indexes of a fitted distribution (module docstring)."""

    #: ``"lognormal"`` or ``"gamma"``: the family with the larger likelihood.
    distribution: str
    median: float
    #: The 99.865 % and 0.135 % points of the fitted distribution.
    p99865: float
    p00135: float
    cp: float | None
    cpu: float | None
    cpl: float | None
    cpk: float | None
    #: Bootstrap interval of ``cpk`` at :data:`CONFIDENCE`.
    cpk_ci: tuple[float, float] | None


@dataclass(frozen=True)
class Capability:
    """Mean, standard deviation and capability indexes of one figure against its limits
    (figure's unit; indexes dimensionless, None where undefined: ``cp`` needs both
    limits, ``cpu`` an upper one, ``cpl`` a lower one)."""

    n: int
    mean: float | None
    std: float | None
    limit: float | None
    cp: float | None
    cpk: float | None
    #: Share of the values above the upper limit (0..1).
    above_limit: float | None
    lower_limit: float | None = None
    cpu: float | None = None
    cpl: float | None = None
    #: Normal-approximation interval of ``cpk`` at :data:`CONFIDENCE`.
    cpk_ci: tuple[float, float] | None = None
    #: The percentile indexes of a fitted lognormal or gamma; None when a value is <= 0
    #: or there are fewer than :data:`MIN_FIT_VALUES`.
    fitted: FittedCapability | None = None


@dataclass(frozen=True)
class ControlChart:
    """Individuals chart of values in test order: centre line, 3-sigma limits from the
    moving range, and the indexes of the values beyond them."""

    center: float | None
    sigma: float | None
    ucl: float | None
    lcl: float | None
    out_of_control: tuple[int, ...]


def capability(values: ArrayLike, upper_limit: float | None,
               lower_limit: float | None = None) -> Capability:
    """Cpu, Cpl, Cpk (and Cp with both limits) of ``values``, normal and fitted (module
    docstring).

    Values that are NaN are left out. With fewer than two values, a zero spread or no
    limit, the indexes are None.
    """
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    n = len(x)
    mean = float(np.mean(x)) if n else None
    std = float(np.std(x, ddof=1)) if n >= 2 else None
    above = float(np.mean(x > upper_limit)) if upper_limit is not None and n else None
    if mean is None or std is None or std <= 0:
        return Capability(n, mean, std, upper_limit, None, None, above, lower_limit)
    cp, cpu, cpl, cpk = _indexes(upper_limit, lower_limit, mean, mean - 3 * std,
                                 mean + 3 * std)
    ci = None
    if cpk is not None:
        half = _Z * math.sqrt(1.0 / (9.0 * n) + cpk**2 / (2.0 * (n - 1)))
        ci = (cpk - half, cpk + half)
    return Capability(n, mean, std, upper_limit, cp, cpk, above, lower_limit, cpu, cpl, ci,
                      fitted_capability(x, upper_limit, lower_limit))


#: Two-sided level of the indexes' intervals.
CONFIDENCE = 0.95
_Z = float(stats.norm.ppf(0.5 + CONFIDENCE / 2))
#: Bootstrap of the fitted indexes: resamples and the fixed seed they are drawn with.
BOOTSTRAP_RESAMPLES = 1000
BOOTSTRAP_SEED = 22514
#: Fewest values a distribution is fitted to.
MIN_FIT_VALUES = 5
#: The percentiles ISO 22514-4 puts in place of mean +- 3 sigma.
P_HIGH, P_LOW = 0.99865, 0.00135


def _indexes(upper: float | None, lower: float | None, center: float, low: float,
             high: float) -> tuple[float | None, float | None, float | None, float | None]:
    """(Cp, Cpu, Cpl, Cpk) from a centre and the points standing for -3 and +3 sigma."""
    cpu = (upper - center) / (high - center) if upper is not None else None
    cpl = (center - lower) / (center - low) if lower is not None else None
    cp = (upper - lower) / (high - low) if upper is not None and lower is not None else None
    sides = [c for c in (cpu, cpl) if c is not None]
    return cp, cpu, cpl, (min(sides) if sides else None)


def _fit(x: NDArray[np.float64], family: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Maximum-likelihood parameters of ``family`` (location 0) of each row of ``x``:
    lognormal (mu, sigma of the logs), gamma (shape, scale; Newton on the shape's
    likelihood equation ``log k - digamma(k) = log(mean) - mean(log x)``)."""
    logs = np.log(x)
    if family == "lognormal":
        return logs.mean(axis=-1), logs.std(axis=-1)
    mean = x.mean(axis=-1)
    gap = np.maximum(np.log(mean) - logs.mean(axis=-1), 1e-12)
    k = (3 - gap + np.sqrt((gap - 3) ** 2 + 24 * gap)) / (12 * gap)  # Minka's start
    for _ in range(6):
        k = k - (np.log(k) - special.digamma(k) - gap) / (1 / k - special.polygamma(1, k))
    return k, mean / k


def _percentiles(family: str, a: NDArray[np.float64], b: NDArray[np.float64]
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """(X0.135, X50, X99.865) of the fitted distributions."""
    if family == "lognormal":
        dist = stats.lognorm(b, scale=np.exp(a))
    else:
        dist = stats.gamma(a, scale=b)
    return dist.ppf(P_LOW), dist.ppf(0.5), dist.ppf(P_HIGH)


def fitted_capability(values: NDArray[np.float64], upper_limit: float | None,
                      lower_limit: float | None = None) -> FittedCapability | None:
    """ISO 22514-4 percentile indexes of positive ``values`` (module docstring)."""
    x = np.asarray(values, dtype=float)
    if len(x) < MIN_FIT_VALUES or (x <= 0).any() or np.ptp(x) <= 0:
        return None
    likelihood = {
        "lognormal": float(np.sum(stats.lognorm.logpdf(x, _fit(x, "lognormal")[1],
                                                       scale=np.exp(_fit(x, "lognormal")[0])))),
        "gamma": float(np.sum(stats.gamma.logpdf(x, _fit(x, "gamma")[0],
                                                 scale=_fit(x, "gamma")[1]))),
    }
    family = max(likelihood, key=lambda f: likelihood[f])
    low, mid, high = (float(v) for v in _percentiles(family, *_fit(x, family)))
    cp, cpu, cpl, cpk = _indexes(upper_limit, lower_limit, mid, low, high)
    ci = None
    if cpk is not None:
        rng = np.random.default_rng(BOOTSTRAP_SEED)
        resamples = x[rng.integers(0, len(x), size=(BOOTSTRAP_RESAMPLES, len(x)))]
        spread = np.ptp(resamples, axis=1) > 0
        lows, mids, highs = _percentiles(family, *_fit(resamples[spread], family))
        boot = np.minimum(*(np.asarray(v) for v in (
            (upper_limit - mids) / (highs - mids) if upper_limit is not None else np.inf,
            (mids - lower_limit) / (mids - lows) if lower_limit is not None else np.inf)))
        tail = 50 * (1 - CONFIDENCE)
        ci = (float(np.percentile(boot, tail)), float(np.percentile(boot, 100 - tail)))
    return FittedCapability(family, mid, high, low, cp, cpu, cpl, cpk, ci)


def individuals_chart(values: ArrayLike) -> ControlChart:
    """Shewhart individuals chart of ``values`` in test order (module docstring); NaN values
    are left out of the limits and never flagged, nor is anything when the values do not
    vary (limits equal to the centre line)."""
    x = np.asarray(values, dtype=float)
    finite = np.isfinite(x)
    v = x[finite]
    if len(v) < 2:
        return ControlChart(float(v[0]) if len(v) else None, None, None, None, ())
    center = float(np.mean(v))
    sigma = float(np.mean(np.abs(np.diff(v)))) / D2_MOVING_RANGE
    if sigma <= 1e-12 * max(abs(center), 1e-300):  # no variation: no point is out of control
        return ControlChart(center, 0.0, center, center, ())
    ucl, lcl = center + 3 * sigma, center - 3 * sigma
    out = tuple(int(i) for i in np.flatnonzero(finite & ((x > ucl) | (x < lcl))))
    return ControlChart(center, sigma, ucl, lcl, out)


def finite_or_none(value: float | None) -> float | None:
    """``value`` when it is a finite number, else None (for JSON)."""
    return value if value is not None and math.isfinite(value) else None


#: What the capability columns mean, under the tables of ``results --stats`` and the PDF.
CAPABILITY_NOTE = (
    "Ppk (upper) = (limit - mean) / 3 s, one-sided (no Cp: no lower limit), interval "
    "+-z sqrt(1/9n + Ppk^2/2(n-1)); Ppk fitted = (limit - X50) / (X99.865 - X50) of the "
    "lognormal or gamma with the larger likelihood (ISO 22514-4), bootstrap interval "
    f"({BOOTSTRAP_RESAMPLES} resamples, seed {BOOTSTRAP_SEED})"
)
