"""Moved to :mod:`analysis.reconcile.gmwm_naming`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.moved import warn_moved
from analysis.reconcile.gmwm_naming import (
    ALTERNATIVE_SCORE as ALTERNATIVE_SCORE,
    GMWM_CODE as GMWM_CODE,
    JUDGE_MIN_BLOCKS as JUDGE_MIN_BLOCKS,
    Alternative as Alternative,
    GmwmJudgement as GmwmJudgement,
    T as T,
    base_codes as base_codes,
    judge as judge,
    new_or_more as new_or_more,
)

warn_moved("analysis.gmwm_naming", "analysis.reconcile.gmwm_naming")
