"""Moved to :mod:`analysis.models.noise`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.models.noise import (
    MarkovBank as MarkovBank,
    SampledBank as SampledBank,
    flicker_bank as flicker_bank,
    flicker_rate_noise as flicker_rate_noise,
    kasdin_coefficients as kasdin_coefficients,
    random_walk_rate_noise as random_walk_rate_noise,
    rate_ramp as rate_ramp,
    sample_bank as sample_bank,
    white_angle_noise as white_angle_noise,
    white_rate_noise as white_rate_noise,
)
from analysis.moved import warn_moved

warn_moved("analysis.noise", "analysis.models.noise")
