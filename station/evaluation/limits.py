"""The deciding grade's limits as lines on an Allan deviation plot (deg/h over tau in s).

Every view of a graded axis (the spec sheets' Allan panel, the TUI's Allan tab) draws
these: the ARW limit as a slope -1/2 line, the bias-instability limit as the level of
the Allan deviation's flat part (0.664 B, IEEE Std 952 Annex C), the Allan-minimum limit
as a level.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from analysis.figures.readoffs import BIAS_INSTABILITY_FACTOR
from analysis.units.conversions import S_PER_H
from station.evaluation.grading import AxisGrade

#: ARW figures (deg/sqrt(h)): drawn as N / sqrt(tau).
ARW_FIGURES = ("arw", "arw_fit")
#: Level figures (deg/h): bias instability (drawn at 0.664 B) and the Allan minimum.
LEVEL_FIGURES = ("bias_instability", "bias_instability_fit", "adev_min")


@dataclass(frozen=True, eq=False)  # arrays: compared by identity
class LimitLine:
    """One limit of an axis' deciding grade as a line of Allan deviation (deg/h) over tau (s)."""

    figure: str
    label: str
    grade: str
    shape: Literal["slope", "level"]
    tau_s: NDArray[np.float64]
    adev_deg_h: NDArray[np.float64]


def limit_lines(axis: AxisGrade) -> list[LimitLine]:
    """The deciding grade's ARW and bias-instability (or Allan-minimum) limits of ``axis``
    on its Allan grid."""
    tau = axis.analysis.allan.tau_s
    out = []
    for f in axis.figures:
        limit = f.spec.limits.get(axis.deciding_grade)
        if limit is None:
            continue
        canonical = limit * f.spec.unit_factor
        if f.name in ARW_FIGURES:  # deg/sqrt(h) -> deg/h at tau: N / sqrt(tau) * 60
            out.append(LimitLine(f.name, f.spec.label, axis.deciding_grade, "slope", tau,
                                 canonical * math.sqrt(S_PER_H) / np.sqrt(tau)))
        elif f.name in LEVEL_FIGURES:
            level = canonical * (BIAS_INSTABILITY_FACTOR if f.name != "adev_min" else 1.0)
            out.append(LimitLine(f.name, f.spec.label, axis.deciding_grade, "level", tau,
                                 np.full(len(tau), level)))
    return out
