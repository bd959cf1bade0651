"""Moved to :mod:`analysis.fit.result`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.fit.result import (
    GM_B_EQUIVALENT as GM_B_EQUIVALENT,
    Alternative as Alternative,
    GaussMarkovReading as GaussMarkovReading,
    NoiseCoefficients as NoiseCoefficients,
)
from analysis.moved import warn_moved

warn_moved("analysis.fit_result", "analysis.fit.result")
