"""Moved to :mod:`analysis.fit.uncertainty`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.fit.uncertainty import (
    ANCHORS as ANCHORS,
    J_STEPS as J_STEPS,
    MAX_EXACT_TAUS as MAX_EXACT_TAUS,
    MISFIT_GATE as MISFIT_GATE,
    MISFIT_OCTAVES as MISFIT_OCTAVES,
    MISFIT_PRECISION as MISFIT_PRECISION,
    MISFIT_WINDOW_OCTAVES as MISFIT_WINDOW_OCTAVES,
    RELATIVE_VARIANCE_FLOOR as RELATIVE_VARIANCE_FLOOR,
    SMALL_M as SMALL_M,
    LinearizedFit as LinearizedFit,
    ValueCovariance as ValueCovariance,
    value_covariance as value_covariance,
)
from analysis.moved import warn_moved

warn_moved("analysis.fit_uncertainty", "analysis.fit.uncertainty")
