"""Moved to :mod:`analysis.models.fog`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.models.fog import (
    BiasStabilityStatistics as BiasStabilityStatistics,
    FogParameters as FogParameters,
    averaged_variance_factor as averaged_variance_factor,
    bias_stability_statistics as bias_stability_statistics,
    fog_from_indicators as fog_from_indicators,
    measure_arw as measure_arw,
    measure_bias_stability as measure_bias_stability,
)
from analysis.moved import warn_moved

warn_moved("analysis.fog", "analysis.models.fog")
