"""Moved to :mod:`analysis.figures.ambiguity`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.figures.ambiguity import (
    AMBIGUITY_MARGIN as AMBIGUITY_MARGIN,
    GMWM_TERM as GMWM_TERM,
    WALK_LOOKALIKES as WALK_LOOKALIKES,
    resolve_ambiguity as resolve_ambiguity,
    resolve_for_rate as resolve_for_rate,
    wavelet_criterion_delta as wavelet_criterion_delta,
)
from analysis.moved import warn_moved

warn_moved("analysis.ambiguity", "analysis.figures.ambiguity")
