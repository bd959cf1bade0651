"""Units: conversions between the data-sheet units of the noise terms and the base units
(deg, s), the unit families a report prints in, and the Earth's rate a bench sees.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analysis.lazy import import_export

#: public name -> the module that defines it (imported on first use)
EXPORTS: dict[str, str] = {
    "DEG_FAMILY": "analysis.units.conversions",
    "DEG_PER_URAD": "analysis.units.conversions",
    "FAMILY_UNITS": "analysis.units.conversions",
    "FamilyUnit": "analysis.units.conversions",
    "RAD_FAMILY": "analysis.units.conversions",
    "RAD_PER_DEG": "analysis.units.conversions",
    "STANDARD_GRAVITY_M_S2": "analysis.units.conversions",
    "S_PER_H": "analysis.units.conversions",
    "UNIT_FAMILIES": "analysis.units.conversions",
    "UnitFamily": "analysis.units.conversions",
    "UnitFamilyName": "analysis.units.conversions",
    "arw_deg_rt_h_to_deg_rt_s": "analysis.units.conversions",
    "arw_deg_rt_s_to_deg_rt_h": "analysis.units.conversions",
    "earth_rate_by_axis": "analysis.units.earth",
    "earth_rate_on_axis_deg_h": "analysis.units.earth",
    "family_unit": "analysis.units.conversions",
    "family_unit_of_key": "analysis.units.conversions",
    "parse_orientation": "analysis.units.earth",
    "q_deg_to_urad": "analysis.units.conversions",
    "q_urad_to_deg": "analysis.units.conversions",
    "ramp_deg_h2_to_deg_s2": "analysis.units.conversions",
    "ramp_deg_s2_to_deg_h2": "analysis.units.conversions",
    "rate_deg_h_to_deg_s": "analysis.units.conversions",
    "rate_deg_s_to_deg_h": "analysis.units.conversions",
    "rrw_deg_h_1_5_to_deg_s_1_5": "analysis.units.conversions",
    "rrw_deg_s_1_5_to_deg_h_1_5": "analysis.units.conversions",
    "unit_family": "analysis.units.conversions",
}

__all__ = sorted(EXPORTS)

if TYPE_CHECKING:
    from analysis.units.conversions import (
        DEG_FAMILY as DEG_FAMILY,
        DEG_PER_URAD as DEG_PER_URAD,
        FAMILY_UNITS as FAMILY_UNITS,
        RAD_FAMILY as RAD_FAMILY,
        RAD_PER_DEG as RAD_PER_DEG,
        S_PER_H as S_PER_H,
        STANDARD_GRAVITY_M_S2 as STANDARD_GRAVITY_M_S2,
        UNIT_FAMILIES as UNIT_FAMILIES,
        FamilyUnit as FamilyUnit,
        UnitFamily as UnitFamily,
        UnitFamilyName as UnitFamilyName,
        arw_deg_rt_h_to_deg_rt_s as arw_deg_rt_h_to_deg_rt_s,
        arw_deg_rt_s_to_deg_rt_h as arw_deg_rt_s_to_deg_rt_h,
        family_unit as family_unit,
        family_unit_of_key as family_unit_of_key,
        q_deg_to_urad as q_deg_to_urad,
        q_urad_to_deg as q_urad_to_deg,
        ramp_deg_h2_to_deg_s2 as ramp_deg_h2_to_deg_s2,
        ramp_deg_s2_to_deg_h2 as ramp_deg_s2_to_deg_h2,
        rate_deg_h_to_deg_s as rate_deg_h_to_deg_s,
        rate_deg_s_to_deg_h as rate_deg_s_to_deg_h,
        rrw_deg_h_1_5_to_deg_s_1_5 as rrw_deg_h_1_5_to_deg_s_1_5,
        rrw_deg_s_1_5_to_deg_h_1_5 as rrw_deg_s_1_5_to_deg_h_1_5,
        unit_family as unit_family,
    )
    from analysis.units.earth import (
        earth_rate_by_axis as earth_rate_by_axis,
        earth_rate_on_axis_deg_h as earth_rate_on_axis_deg_h,
        parse_orientation as parse_orientation,
    )


def __getattr__(name: str) -> object:
    """A public name, imported from its module on first use (PEP 562)."""
    return import_export(globals(), EXPORTS, name)
