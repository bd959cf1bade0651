"""Moved to :mod:`analysis.allan.confidence`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.allan.confidence import (
    DENSE_LAGS as DENSE_LAGS,
    EDF_EXACT_POINTS as EDF_EXACT_POINTS,
    FLICKER_LAG_LIMIT_M as FLICKER_LAG_LIMIT_M,
    LAG_SAMPLES_PER_M as LAG_SAMPLES_PER_M,
    LAG_WINDOW as LAG_WINDOW,
    NOISE_ALPHAS as NOISE_ALPHAS,
    ONE_SIGMA as ONE_SIGMA,
    allan_edf as allan_edf,
    allan_edf_grid as allan_edf_grid,
    chi2_interval as chi2_interval,
    difference_autocovariance as difference_autocovariance,
    difference_edf as difference_edf,
    difference_edf_grid as difference_edf_grid,
    estimator_terms as estimator_terms,
    local_noise_alpha as local_noise_alpha,
    overlapping_edf as overlapping_edf,
    second_difference_autocovariance as second_difference_autocovariance,
)
from analysis.moved import warn_moved

warn_moved("analysis.confidence", "analysis.allan.confidence")
