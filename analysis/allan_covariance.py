"""Moved to :mod:`analysis.allan.covariance`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.allan.covariance import (
    EXACT_CHUNK as EXACT_CHUNK,
    EXACT_LAGS as EXACT_LAGS,
    EXACT_PAIRS as EXACT_PAIRS,
    FLICKER_TAIL_M as FLICKER_TAIL_M,
    NEAR_POSITIONS as NEAR_POSITIONS,
    QUADRATURE_CHUNK as QUADRATURE_CHUNK,
    RANDOM_TERMS as RANDOM_TERMS,
    UNIFORM_PERIODS as UNIFORM_PERIODS,
    CovarianceBasis as CovarianceBasis,
    covariance_basis as covariance_basis,
)
from analysis.moved import warn_moved

warn_moved("analysis.allan_covariance", "analysis.allan.covariance")
