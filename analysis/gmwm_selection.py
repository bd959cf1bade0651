"""Moved to :mod:`analysis.gmwm.selection`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.gmwm.selection import (
    AUTO_CANDIDATES as AUTO_CANDIDATES,
    GmwmSelection as GmwmSelection,
    RankedModel as RankedModel,
    auto_candidates as auto_candidates,
    effective_model as effective_model,
    gmwm_analysis as gmwm_analysis,
    select_model as select_model,
)
from analysis.moved import warn_moved

warn_moved("analysis.gmwm_selection", "analysis.gmwm.selection")
