"""The deviation curve of every axis as CSV (``station analyze --csv OUT``), in deg/h (or
rad/s, ``--output-units rad``); accelerometer axes in m/s^2 in a file of their own
(``<stem>_accel.csv``, columns ending in ``_m_s2``; ``_m_s`` for ``tdev``).

One row per axis and tau (long format: axes may have different tau grids), columns
``axis, tau_s, <kind>_deg_h, <kind>_ci_low_deg_h, <kind>_ci_high_deg_h, n_clusters`` and,
for the Allan deviation the fit was made on, ``fit_adev_deg_h`` (the fitted five-term
model at that tau). A time deviation (``tdev``, an angle) is in deg: ``tdev_deg``... In the
rad family the columns end in ``_rad_s`` (``_rad`` for ``tdev``), the values converted by
:data:`analysis.units.FAMILY_UNITS`.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from analysis.allan.deviations import from_allan
from analysis.units.conversions import DEG_FAMILY, S_PER_H, UnitFamily, family_unit
from station.evaluation.analyze import AxisAnalysis
from station.storage.atomic_files import write_text_atomically


def _key_unit(label: str, family: UnitFamily) -> str:
    """How a column name ends in the unit a deg-family ``label`` is written in (``deg_h``,
    ``rad_s``)."""
    named = family_unit(label)
    if named is None:
        raise ValueError(f"{label!r} is not a deg-family unit")
    return named.key if family.name == "deg" else named.rad_key


def curve_table(axes: Sequence[AxisAnalysis], family: UnitFamily = DEG_FAMILY) -> str:
    """The CSV text of the shown curve of every axis in ``family`` (the module docstring lists
    the columns)."""
    shown = [a.shown for a in axes]
    kind = shown[0].kind if shown else "oadev"
    angle = bool(shown) and shown[0].unit == "angle"
    rate = S_PER_H * family.factor("deg/h")  # deg/s -> the rate unit written
    label, scale = ("deg", family.factor("deg")) if angle else ("deg/h", rate)
    unit, rate_unit = _key_unit(label, family), _key_unit("deg/h", family)
    if axes and axes[0].accel is not None:  # accelerometers: m/s^2 as analysed, SI always
        rate, scale, unit, rate_unit = 1.0, 1.0, "m_s" if angle else "m_s2", "m_s2"
    fitted = all(c.kind == from_allan(a.allan).kind for a, c in zip(axes, shown, strict=True))
    header = [
        "axis",
        "tau_s",
        f"{kind}_{unit}",
        f"{kind}_ci_low_{unit}",
        f"{kind}_ci_high_{unit}",
        "n_clusters",
        *([f"fit_adev_{rate_unit}"] if fitted else []),
    ]
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    for axis, c in zip(axes, shown, strict=True):
        fit = np.sqrt(axis.fit.model_avar(c.tau_s)) * rate if fitted else None
        for i, tau in enumerate(c.tau_s):
            row: list[object] = [axis.name, repr(float(tau))]
            for v in (c.deviation[i], c.deviation_ci_low[i], c.deviation_ci_high[i]):
                row.append(repr(float(v) * scale) if math.isfinite(v) else "")
            row.append(int(c.n_clusters[i]))
            if fit is not None:
                row.append(repr(float(fit[i])))
            writer.writerow(row)
    return out.getvalue()


def write_curve_csv(axes: Sequence[AxisAnalysis], path: str | Path,
                    family: UnitFamily = DEG_FAMILY) -> Path:
    """Write :func:`curve_table` (in ``family``) of the rate axes to ``path`` whole or not
    at all, and of the accelerometer axes to ``<stem>_accel<suffix>`` beside it."""
    path = Path(path)
    rates = [a for a in axes if a.accel is None]
    accel = [a for a in axes if a.accel is not None]
    if accel:
        write_text_atomically(accel_path(path), curve_table(accel, family))
    return write_text_atomically(path, curve_table(rates, family)) if rates else path


def accel_path(path: Path) -> Path:
    """Where the accelerometer axes' curve goes beside ``path``."""
    return path.with_name(f"{path.stem}_accel{path.suffix}")
