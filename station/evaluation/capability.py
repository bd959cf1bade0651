"""Process capability and control charts of a graded figure over many units.

Every limit of a gyro profile is an upper limit, and every graded figure is a magnitude
(noise densities, instabilities, ``|bias|``) with the natural lower bound 0. So:

``Cpk = (USL - mean) / (3 s)``
    the one-sided index of an upper specification (ISO 22514-2's ``C_pk,U``);
``Cp = (USL - 0) / (6 s)``
    the spread against the whole tolerance between the natural bound 0 and the limit,
    as ISO 22514-2 does for a characteristic with a natural lower limit;

``s`` is the sample standard deviation of all the values (ddof 1): units are tested one at
a time, there are no rational subgroups, so this is the long-term sigma (what AIAG calls
Pp/Ppk). The control chart is Shewhart's individuals chart (Montgomery, *Introduction to
Statistical Quality Control*, 6th ed., sec. 6.4): centre line the mean, limits
``mean +- 3 MR/d2`` with ``MR`` the mean moving range of consecutive values in test order
and ``d2 = 1.128`` (n = 2); a value beyond a limit is out of control (rule 1 of the
Western Electric rules).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

#: d2 of a moving range of two consecutive values (Montgomery, Appendix table VI).
D2_MOVING_RANGE = 1.128


@dataclass(frozen=True)
class Capability:
    """Mean, standard deviation and capability indexes of one figure against its limit
    (figure's unit; indexes dimensionless, None where undefined)."""

    n: int
    mean: float | None
    std: float | None
    limit: float | None
    cp: float | None
    cpk: float | None
    #: Share of the values above the limit (0..1).
    above_limit: float | None


@dataclass(frozen=True)
class ControlChart:
    """Individuals chart of values in test order: centre line, 3-sigma limits from the
    moving range, and the indexes of the values beyond them."""

    center: float | None
    sigma: float | None
    ucl: float | None
    lcl: float | None
    out_of_control: tuple[int, ...]


def capability(values: ArrayLike, upper_limit: float | None) -> Capability:
    """Cp and Cpk of ``values`` against ``upper_limit`` (module docstring).

    Values that are NaN are left out. With fewer than two values, a zero spread or no
    limit, the indexes are None.
    """
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    n = len(x)
    mean = float(np.mean(x)) if n else None
    std = float(np.std(x, ddof=1)) if n >= 2 else None
    cp = cpk = above = None
    if upper_limit is not None and n:
        above = float(np.mean(x > upper_limit))
    if upper_limit is not None and mean is not None and std is not None and std > 0:
        cp = upper_limit / (6.0 * std)
        cpk = (upper_limit - mean) / (3.0 * std)
    return Capability(n, mean, std, upper_limit, cp, cpk, above)


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
