"""Conversions between the data-sheet units of gyro noise terms and the base units (deg, s),
and between the two unit families an output is printed in (deg and rad, ``docs/units.md``).

The analysis works in deg/s for rate and seconds for tau, so a fitted coefficient comes
out in deg-s units; these factors turn it into what a data sheet prints. An output command
prints the deg family by default and the rad family (SI) on request (:class:`UnitFamily`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np
from numpy.typing import NDArray

#: deg per microradian.
DEG_PER_URAD = 1e-6 * 180.0 / math.pi
#: seconds per hour.
S_PER_H = 3600.0
#: Standard gravity, m/s^2 (the unit g of accelerometer data sheets; CGPM 1901).
STANDARD_GRAVITY_M_S2 = 9.80665


def q_urad_to_deg(q_urad: float) -> float:
    """Quantization coefficient: microradian -> deg."""
    return q_urad * DEG_PER_URAD


def q_deg_to_urad(q_deg: float) -> float:
    """Quantization coefficient: deg -> microradian."""
    return q_deg / DEG_PER_URAD


def arw_deg_rt_h_to_deg_rt_s(n: float) -> float:
    """Angle random walk: deg/sqrt(h) -> deg/sqrt(s) (divide by 60)."""
    return n / math.sqrt(S_PER_H)


def arw_deg_rt_s_to_deg_rt_h(n: float) -> float:
    """Angle random walk: deg/sqrt(s) -> deg/sqrt(h) (multiply by 60)."""
    return n * math.sqrt(S_PER_H)


def rate_deg_h_to_deg_s(b: float) -> float:
    """A rate (bias, bias instability): deg/h -> deg/s."""
    return b / S_PER_H


def rate_deg_s_to_deg_h(b: float) -> float:
    """A rate (bias, bias instability): deg/s -> deg/h."""
    return b * S_PER_H


def rrw_deg_h_1_5_to_deg_s_1_5(k: float) -> float:
    """Rate random walk: deg/h^1.5 -> deg/s^1.5."""
    return float(k / S_PER_H**1.5)


def rrw_deg_s_1_5_to_deg_h_1_5(k: float) -> float:
    """Rate random walk: deg/s^1.5 -> deg/h^1.5."""
    return float(k * S_PER_H**1.5)


def ramp_deg_h2_to_deg_s2(r: float) -> float:
    """Rate ramp: deg/h^2 -> deg/s^2."""
    return r / S_PER_H**2


def ramp_deg_s2_to_deg_h2(r: float) -> float:
    """Rate ramp: deg/s^2 -> deg/h^2."""
    return r * S_PER_H**2


# --- output unit families ----------------------------------------------------------------

#: radians per degree.
RAD_PER_DEG = math.pi / 180.0

#: The unit families an output is printed in: ``deg`` (data-sheet units: deg/h, deg/sqrt(h),
#: deg/h^1.5, deg/h^2, urad) or ``rad`` (SI: rad/s, rad/s/sqrt(Hz), rad/s^2/sqrt(Hz), rad/s^2,
#: rad).
UnitFamilyName = Literal["deg", "rad"]
UNIT_FAMILIES: tuple[UnitFamilyName, ...] = get_args(UnitFamilyName)


@dataclass(frozen=True)
class FamilyUnit:
    """One deg-family unit and its rad-family counterpart.

    ``label`` is the unit as a table prints it (``deg/h``), ``key`` as a JSON key ends in it
    (``deg_h``); ``rad_per_deg`` is how many rad-family units one deg-family unit is.
    """

    label: str
    key: str
    rad_label: str
    rad_key: str
    rad_per_deg: float


#: Every deg-family unit the station prints and its SI (rad-family) counterpart
#: (``docs/units.md``): a rate in rad/s, the angle random walk as the continuous noise density
#: N in rad/s/sqrt(Hz) (= rad/sqrt(s)), the rate random walk K in rad/s^2/sqrt(Hz)
#: (= rad/s^1.5), the rate ramp R in rad/s^2, the quantization Q and angles in rad, a
#: (wavelet) variance of the rate in (rad/s)^2.
FAMILY_UNITS: tuple[FamilyUnit, ...] = (
    FamilyUnit("deg/h", "deg_h", "rad/s", "rad_s", RAD_PER_DEG / S_PER_H),
    FamilyUnit("deg/s", "deg_s", "rad/s", "rad_s", RAD_PER_DEG),
    FamilyUnit("deg/sqrt(h)", "deg_rt_h", "rad/s/sqrt(Hz)", "rad_s_rt_hz",
               RAD_PER_DEG / math.sqrt(S_PER_H)),
    FamilyUnit("deg/h^1.5", "deg_h_1_5", "rad/s^2/sqrt(Hz)", "rad_s2_rt_hz",
               RAD_PER_DEG / S_PER_H**1.5),
    FamilyUnit("deg/h/sqrt(h)", "deg_h_rt_h", "rad/s^2/sqrt(Hz)", "rad_s2_rt_hz",
               RAD_PER_DEG / S_PER_H**1.5),
    FamilyUnit("deg/h^2", "deg_h2", "rad/s^2", "rad_s2", RAD_PER_DEG / S_PER_H**2),
    FamilyUnit("urad", "urad", "rad", "rad", 1e-6),
    FamilyUnit("deg", "deg", "rad", "rad", RAD_PER_DEG),
    FamilyUnit("(deg/s)^2", "deg2_s2", "(rad/s)^2", "rad2_s2", RAD_PER_DEG**2),
)
_BY_LABEL = {u.label: u for u in FAMILY_UNITS}
_BY_KEY = {u.key: u for u in FAMILY_UNITS}


def family_unit(label: str) -> FamilyUnit | None:
    """The :class:`FamilyUnit` of a deg-family unit label (``"deg/h"``), None for another unit
    (``"s"``, ``"Hz"``, ``"degC"``: the same in both families)."""
    return _BY_LABEL.get(label)


def family_unit_of_key(key: str) -> tuple[str, FamilyUnit, str] | None:
    """Split a JSON key named with a deg-family unit: ``"N_deg_rt_h_stderr"`` ->
    ``("N", <deg/sqrt(h)>, "_stderr")``; None when the key names no such unit.

    The unit is the longest one the key ends in, before an optional ``_stderr``.
    """
    stem, tail = (key[: -len("_stderr")], "_stderr") if key.endswith("_stderr") else (key, "")
    parts = stem.split("_")
    for i in range(1, len(parts)):
        unit = _BY_KEY.get("_".join(parts[i:]))
        if unit is not None:
            return "_".join(parts[:i]), unit, tail
    return None


@dataclass(frozen=True)
class UnitFamily:
    """How an output prints a deg-family figure: in the deg family (unchanged) or in the rad
    family (SI), through :data:`FAMILY_UNITS`.

    ``family.value(x, "deg/h")`` is ``x`` deg/h in this family's unit, ``family.label("deg/h")``
    that unit's label; a unit outside :data:`FAMILY_UNITS` (s, Hz, degC) passes unchanged.
    """

    name: UnitFamilyName = "deg"

    def factor(self, label: str) -> float:
        """How many of this family's units one ``label`` (deg family) is."""
        unit = _BY_LABEL.get(label)
        return 1.0 if self.name == "deg" or unit is None else unit.rad_per_deg

    def label(self, label: str) -> str:
        """The unit a deg-family ``label`` is printed in."""
        unit = _BY_LABEL.get(label)
        return label if self.name == "deg" or unit is None else unit.rad_label

    def value(self, value: float | None, label: str) -> float | None:
        """``value`` (in ``label``, a deg-family unit) in this family; None stays None."""
        return None if value is None else float(value) * self.factor(label)

    def array(self, values: NDArray[np.float64], label: str) -> NDArray[np.float64]:
        """An array of values in ``label`` (deg family) in this family."""
        return np.asarray(values, dtype=float) * self.factor(label)


def unit_family(name: str) -> UnitFamily:
    """The :class:`UnitFamily` named ``name`` (``deg`` or ``rad``).

    Raises
    ------
    ValueError
        For another name.
    """
    if name not in UNIT_FAMILIES:
        raise ValueError(f"unknown unit family {name!r}; use one of {', '.join(UNIT_FAMILIES)}")
    return UnitFamily(name)


#: The deg family: every figure as the station computes it (the default of every output).
DEG_FAMILY = UnitFamily("deg")
#: The rad family (SI).
RAD_FAMILY = UnitFamily("rad")
