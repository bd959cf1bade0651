"""A ``--json`` document in the rad unit family (``--output-units rad``, ``docs/json.md``).

Every JSON document the station prints is built in the deg family, each quantity named with
its unit: a key ending in the unit (``bias_deg_h``, ``N_deg_rt_h_stderr``, ``adev_deg_h``) or
an object with a ``"unit"`` field (a graded figure, a trend point, a production statistic).
:func:`to_rad_family` rewrites such a document once, by those names, with the factors of
:data:`analysis.units.FAMILY_UNITS`: ``bias_deg_h`` becomes ``bias_rad_s``,
``N_deg_rt_h_stderr`` becomes ``N_rad_s_rt_hz_stderr``, a figure ``{"unit": "deg/h", "value":
...}`` becomes ``{"unit": "rad/s", "value": ...}``, the readings under its ``alternatives``
with it. The older keys without a unit
(``adev``, in deg/s, beside ``adev_deg_h``; ``terms`` beside ``terms_deg_h``) are left out
of a rad document where their unit-named twin is in the same object, which carries the
values; a key in another unit (``tau_s``, ``sample_rate_hz``) and a key named in
:data:`KEPT_IN_DEG` pass unchanged.
"""

from __future__ import annotations

from collections.abc import Mapping

from analysis.units.conversions import FAMILY_UNITS, UnitFamily, family_unit, family_unit_of_key

#: Keys whose value is kept as it is: ``model_after`` is a noise model's TOML tables, in the
#: units a model file is read in.
KEPT_IN_DEG = frozenset({"model_after"})
#: In an object with a ``"unit"`` field, the fields that hold values in that unit (a
#: production statistic's fitted X50 and X99.865 too; its indexes are dimensionless; the
#: simulated truth beside a figure of ``station demo``).
VALUE_FIELDS = frozenset({"value", "ci_low", "ci_high", "limit", "limits", "truth", "mean", "std",
                          "center", "ucl", "lcl", "out_of_control", "min", "max",
                          "fitted_median", "fitted_p99865"})


def _scaled(value: object, factor: float) -> object:
    """Every number in ``value`` (nested lists and objects) times ``factor``; other values as
    they are."""
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, int | float):
        return float(value) * factor
    if isinstance(value, list | tuple):
        return [_scaled(v, factor) for v in value]
    if isinstance(value, Mapping):
        return {k: _scaled(v, factor) for k, v in value.items()}
    return value


def _has_twin(doc: Mapping[str, object], key: str) -> bool:
    """Whether ``doc`` holds ``key``'s values under a unit-named key too (``adev`` and
    ``adev_deg_h``)."""
    return family_unit_of_key(key) is None and any(f"{key}_{u.key}" in doc for u in FAMILY_UNITS)


def to_rad_family(doc: object) -> object:
    """``doc`` (a ``--json`` document in the deg family) in the rad family.

    Parameters
    ----------
    doc : object
        A JSON-able value: objects, lists, numbers, strings, None.

    Returns
    -------
    object
        A new document; ``doc`` is not changed.
    """
    if isinstance(doc, list | tuple):
        return [to_rad_family(v) for v in doc]
    if not isinstance(doc, Mapping):
        return doc
    unit = family_unit(doc["unit"]) if isinstance(doc.get("unit"), str) else None
    out: dict[str, object] = {}
    for key, value in doc.items():
        if key in KEPT_IN_DEG:
            out[key] = value
        elif _has_twin(doc, key):
            continue
        elif unit is not None and key == "unit":
            out[key] = unit.rad_label
        elif unit is not None and key in VALUE_FIELDS:
            out[key] = _scaled(value, unit.rad_per_deg)
        elif unit is not None and key == "alternatives" and isinstance(value, list):
            # a graded figure's other readings: in the figure's unit
            out[key] = [{k: _scaled(v, unit.rad_per_deg) if k in VALUE_FIELDS else v
                         for k, v in r.items()} if isinstance(r, Mapping) else r
                        for r in value]
        elif key.endswith("unit") and isinstance(value, str):
            named = family_unit(value)
            out[key] = value if named is None else named.rad_label
        elif (split := family_unit_of_key(key)) is not None:
            stem, named, tail = split
            new_key = f"{stem}_{named.rad_key}{tail}"
            if new_key not in out:  # adev_deg_h and adev_deg_s: one adev_rad_s
                out[new_key] = _scaled(to_rad_family(value), named.rad_per_deg)
        else:
            out[key] = to_rad_family(value)
    return out


def in_family(doc: object, family: UnitFamily) -> object:
    """``doc`` in ``family``: as it is for the deg family, :func:`to_rad_family` for rad."""
    return doc if family.name == "deg" else to_rad_family(doc)
