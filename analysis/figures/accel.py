"""Accelerometer figures: local gravity, the gravity each axis reads at rest, and the
accelerometer noise terms read from the same Allan analysis as a gyro's.

The Allan family, the fits and the read-offs are linear in the unit of their input: a
record in m/s^2 analysed by the code that takes deg/s gives every figure in m/s^2 where
the gyro figure says deg/s, with the same time factors. So the gyro figure ``N`` in
"deg/sqrt(h)" of an m/s^2 series is the velocity random walk in m/s/sqrt(h), ``B`` in
"deg/h" is the bias instability in m/s^2 times 3600, ``K`` in "deg/h^1.5" the
acceleration random walk in m/s/h^1.5 (:func:`accel_figures` does the bookkeeping).

The terms are those of IEEE Std 1293-2018 (linear accelerometers, annex C: velocity
random walk, bias instability, acceleration random walk, as IEEE Std 952-1997 annex C
names the gyro's angle random walk, bias instability and rate random walk).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from analysis.figures.spec import SpecFigures
from analysis.fit.result import NoiseCoefficients
from analysis.units.conversions import S_PER_H
from analysis.units.earth import Direction, axis_direction, match_axis

#: Standard gravity (m/s^2), the conventional value of the unit g (CGPM 1901).
STANDARD_GRAVITY_M_S2 = 9.80665

# WGS-84 constants (NIMA TR8350.2, 3rd ed., 2000, tables 3.1-3.3).
_A_M = 6378137.0  # semi-major axis
_F = 1.0 / 298.257223563  # flattening
_GE = 9.7803253359  # normal gravity at the equator, m/s^2
_K = 0.00193185265241  # Somigliana constant k = (b gp) / (a ge) - 1
_E2 = 6.69437999014e-3  # first eccentricity squared
_M = 0.00344978650684  # m = omega^2 a^2 b / GM


def normal_gravity_m_s2(latitude_deg: float, height_m: float = 0.0) -> float:
    """Normal gravity (m/s^2) of the WGS-84 ellipsoid at a geodetic latitude and height.

    Somigliana's closed formula on the ellipsoid, ``g0 = ge (1 + k sin^2 phi) /
    sqrt(1 - e^2 sin^2 phi)`` (NIMA TR8350.2 eq. 4-1), with the free-air correction
    above it to second order in the height, ``g = g0 (1 - 2/a (1 + f + m - 2 f sin^2 phi)
    h + 3 h^2 / a^2)`` (eq. 4-3).

    Parameters
    ----------
    latitude_deg : float
        Geodetic latitude in degrees, -90 .. 90.
    height_m : float
        Height above the ellipsoid in m.

    Raises
    ------
    ValueError
        A latitude outside -90 .. 90 or a non-finite value.
    """
    if not (math.isfinite(latitude_deg) and -90.0 <= latitude_deg <= 90.0):
        raise ValueError(f"latitude must be in -90 .. 90 deg, got {latitude_deg}")
    if not math.isfinite(height_m):
        raise ValueError(f"height must be a finite number of m, got {height_m}")
    s2 = math.sin(math.radians(latitude_deg)) ** 2
    g0 = _GE * (1.0 + _K * s2) / math.sqrt(1.0 - _E2 * s2)
    h = height_m
    return g0 * (1.0 - 2.0 / _A_M * (1.0 + _F + _M - 2.0 * _F * s2) * h + 3.0 * h * h / _A_M**2)


def gravity_by_axis(gravity_m_s2: float, orientation: Mapping[str, Direction],
                    axis_names: Sequence[str]) -> list[float | None]:
    """The specific force (m/s^2) each named accelerometer axis reads at rest: ``g`` times
    the up component of its direction (an axis pointing up reads +g); None for an axis
    the orientation does not give (axis names match as :func:`analysis.units.earth.match_axis`).

    Raises
    ------
    analysis.units.earth.OrientationError
        A bad direction.
    """
    keys = list(orientation)
    out: list[float | None] = []
    for name in axis_names:
        key = match_axis(name, keys)
        out.append(None if key is None
                   else float(gravity_m_s2 * axis_direction(orientation[key])[2]))
    return out


def vertical_axis(means_m_s2: ArrayLike) -> int:
    """Index of the axis whose mean (m/s^2) is nearest +-1 g in magnitude: the vertical one
    when nothing says how the unit sits.

    Raises
    ------
    ValueError
        No axis.
    """
    m = np.abs(np.asarray(means_m_s2, dtype=float).reshape(-1))
    if not m.size:
        raise ValueError("no accelerometer axis to take as the vertical")
    return int(np.argmin(np.abs(m - STANDARD_GRAVITY_M_S2)))


@dataclass(frozen=True)
class AccelFigures:
    """The spec-sheet figures of one accelerometer axis, each in the unit its name ends with.

    ``vrw_m_s_rt_h`` is the velocity random walk read off the -1/2 line at tau = 1 h (IEEE
    Std 1293 annex C's N; ``vrw_upper_bound``: no -1/2 region the curve allows white noise
    in, the value is the white-noise bound, an upper bound whose interval runs from 0,
    :func:`analysis.figures.readoffs.white_noise_bound`), ``vrw_m_s2_rt_hz`` the same as a
    noise density; ``bias_instability_ug``
    the read-off at the Allan minimum divided by 0.664; ``acceleration_random_walk_m_s_h1_5``
    the fitted K; ``accel_bias_mg`` the mean with the gravity projection removed
    (``gravity_removed_m_s2``; None when none was).
    """

    accel_bias_mg: float
    gravity_removed_m_s2: float | None
    vrw_m_s_rt_h: float | None
    vrw_m_s2_rt_hz: float | None
    vrw_ci_m_s_rt_h: tuple[float | None, float | None] | None
    vrw_fit_m_s_rt_h: float | None
    bias_instability_ug: float | None
    bias_instability_mg: float | None
    bias_instability_ci_ug: tuple[float | None, float | None] | None
    bias_instability_tau_s: float | None
    bias_instability_fit_ug: float | None
    acceleration_random_walk_m_s_h1_5: float | None
    acceleration_random_walk_m_s3_rt_hz: float | None
    bias_stability_10s_ug: float | None
    notes: tuple[str, ...] = ()
    vrw_upper_bound: bool = False

    def as_dict(self) -> dict[str, object]:
        """JSON form (tuples become lists)."""
        out: dict[str, Any] = dict(self.__dict__)
        for key in ("vrw_ci_m_s_rt_h", "bias_instability_ci_ug", "notes"):
            value = getattr(self, key)
            out[key] = None if value is None else list(value)
        return out


def _scaled(value: float | None, factor: float) -> float | None:
    return None if value is None else value * factor


def _interval(ci: tuple[float | None, float | None] | None, factor: float
              ) -> tuple[float | None, float | None] | None:
    return None if ci is None else (_scaled(ci[0], factor), _scaled(ci[1], factor))


def accel_figures(figures: SpecFigures, fit: NoiseCoefficients, *,
                  gravity_removed_m_s2: float | None,
                  notes: Sequence[str] = ()) -> AccelFigures:
    """The accelerometer figures of an axis whose series (m/s^2) went through the gyro's
    :func:`analysis.figures.spec_figures` and fit.

    Parameters
    ----------
    figures : analysis.figures.SpecFigures
        Figures of the m/s^2 series (each "deg" in their names reads "m/s^2 ... m").
    fit : analysis.fit.result.NoiseCoefficients
        The fit of the same series.
    gravity_removed_m_s2 : float or None
        Specific force of gravity on this axis (m/s^2) to take off the bias; None: none.
    notes : sequence of str
        What the report says about the bias (which gravity, why).
    """
    ug = 1e6 / STANDARD_GRAVITY_M_S2 / S_PER_H  # "deg/h" of an m/s^2 series -> ug
    mean_m_s2 = figures.bias_deg_h / S_PER_H
    bias = mean_m_s2 - (gravity_removed_m_s2 or 0.0)
    vrw = figures.arw_deg_rt_h
    k = fit.values.get("K")
    return AccelFigures(
        accel_bias_mg=bias / STANDARD_GRAVITY_M_S2 * 1e3,
        gravity_removed_m_s2=gravity_removed_m_s2,
        vrw_m_s_rt_h=vrw,
        vrw_m_s2_rt_hz=_scaled(vrw, 1.0 / math.sqrt(S_PER_H)),
        vrw_ci_m_s_rt_h=figures.arw_ci_deg_rt_h,
        vrw_fit_m_s_rt_h=figures.arw_fit_deg_rt_h,
        bias_instability_ug=_scaled(figures.bias_instability_deg_h, ug),
        bias_instability_mg=_scaled(figures.bias_instability_deg_h, ug * 1e-3),
        bias_instability_ci_ug=_interval(figures.bias_instability_ci_deg_h, ug),
        bias_instability_tau_s=figures.bias_instability_tau_s,
        bias_instability_fit_ug=_scaled(figures.bias_instability_fit_deg_h, ug),
        acceleration_random_walk_m_s_h1_5=k,
        acceleration_random_walk_m_s3_rt_hz=_scaled(k, S_PER_H**-1.5),
        bias_stability_10s_ug=_scaled(figures.bias_stability_10s_deg_h, ug),
        notes=tuple(notes),
        vrw_upper_bound=figures.arw_upper_bound,
    )
