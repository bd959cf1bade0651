"""Moved to :mod:`analysis.fit.model`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.fit.model import (
    BETA_FACTOR as BETA_FACTOR,
    COEFFICIENT_NAMES as COEFFICIENT_NAMES,
    TAU_POWER as TAU_POWER,
    TERMS as TERMS,
    TO_DATASHEET as TO_DATASHEET,
    coefficient as coefficient,
    design_matrix as design_matrix,
    full_beta as full_beta,
    theoretical_avar as theoretical_avar,
)
from analysis.moved import warn_moved

warn_moved("analysis.fit_model", "analysis.fit.model")
