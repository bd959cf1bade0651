"""Moved to :mod:`analysis.allan.noise_id`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.allan.noise_id import (
    ALPHA_RANGE as ALPHA_RANGE,
    FLICKER_RATE_BOUNDARY as FLICKER_RATE_BOUNDARY,
    ID_EXACT_POINTS as ID_EXACT_POINTS,
    MIN_ACF_POINTS as MIN_ACF_POINTS,
    MIN_B1_AVERAGES as MIN_B1_AVERAGES,
    MONOTONE_BELOW_POINTS as MONOTONE_BELOW_POINTS,
    IdMethod as IdMethod,
    NoiseIdentification as NoiseIdentification,
    b1_alpha as b1_alpha,
    b1_expected as b1_expected,
    b1_ratio as b1_ratio,
    identify_noise as identify_noise,
    lag1_alpha as lag1_alpha,
    lag1_autocorrelation as lag1_autocorrelation,
    rn_ratio as rn_ratio,
)
from analysis.moved import warn_moved

warn_moved("analysis.noise_id", "analysis.allan.noise_id")
