"""The chosen deviation of a record's axes as text, a few taus per decade
(``station analyze --deviation``; split from :mod:`station.evaluation.analyze`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from analysis.allan.deviations import DEVIATION_LABELS
from analysis.units.conversions import DEG_FAMILY, UnitFamily

if TYPE_CHECKING:
    from station.evaluation.axis_analysis import AxisAnalysis


def format_curve(axes: list[AxisAnalysis], *, per_decade: int = 3,
                 family: UnitFamily = DEG_FAMILY) -> list[str]:
    """The chosen deviation of every axis at a few taus per decade, with its interval."""
    c0 = axes[0].shown
    deg_unit, deg_scale = ("deg", 1.0) if c0.unit == "angle" else ("deg/h", 3600.0)
    unit, scale = family.label(deg_unit), deg_scale * family.factor(deg_unit)
    lines = ["", f"{DEVIATION_LABELS[c0.kind]} [{unit}] with its {c0.confidence:.3g} interval "
                 f"({c0.interval}); the fit and figures above are on the Allan variance"]
    logt = np.log10(c0.tau_s)
    picks = np.unique(
        [
            int(np.argmin(np.abs(logt - v)))
            for v in np.arange(logt[0], logt[-1] + 1e-9, 1.0 / per_decade)
        ]
        + [len(logt) - 1]
    )
    lines.append(f"{'tau [s]':>10}  " + "  ".join(f"{a.name:>30}" for a in axes))
    for j in picks:
        cells = [f"{a.shown.deviation[j] * scale:.4g} [{a.shown.deviation_ci_low[j] * scale:.3g}, "
                 f"{a.shown.deviation_ci_high[j] * scale:.3g}]" for a in axes]
        lines.append(f"{c0.tau_s[j]:>10.4g}  " + "  ".join(f"{c:>30}" for c in cells))
    for a in axes:
        lines += [f"note ({a.name}): {n}" for n in a.shown.notes]
    return lines
