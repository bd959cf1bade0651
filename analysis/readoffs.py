"""Moved to :mod:`analysis.figures.readoffs`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.figures.readoffs import (
    ARW_SLOPE_TOLERANCE as ARW_SLOPE_TOLERANCE,
    BIAS_INSTABILITY_FACTOR as BIAS_INSTABILITY_FACTOR,
    CORRELATION_BINS_PER_OCTAVE as CORRELATION_BINS_PER_OCTAVE,
    CORRELATION_EXPONENT as CORRELATION_EXPONENT,
    MAX_CANDIDATES as MAX_CANDIDATES,
    SMOOTHING_OCTAVES as SMOOTHING_OCTAVES,
    WHITE_DOMINANCE as WHITE_DOMINANCE,
    ReadOff as ReadOff,
    arw_readoff as arw_readoff,
    bias_instability_readoff as bias_instability_readoff,
    correlated_log_variance as correlated_log_variance,
    local_adev_slope as local_adev_slope,
    smoothed_log_avar as smoothed_log_avar,
    white_share as white_share,
)
from analysis.moved import warn_moved

warn_moved("analysis.readoffs", "analysis.figures.readoffs")
