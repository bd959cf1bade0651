"""Moved to :mod:`analysis.reconcile.confirm`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.moved import warn_moved
from analysis.reconcile.confirm import (
    ALPHA_CONFIRM as ALPHA_CONFIRM,
    AMPLITUDE_AGREEMENT as AMPLITUDE_AGREEMENT,
    DETERMINISTIC as DETERMINISTIC,
    GM_TAU_LIMIT as GM_TAU_LIMIT,
    RAMP_AGREEMENT as RAMP_AGREEMENT,
    STEP_BLOCK_COUNTS as STEP_BLOCK_COUNTS,
    Z_CONFIRM as Z_CONFIRM,
    Evidence as Evidence,
    RoundEvidence as RoundEvidence,
    StepEvidence as StepEvidence,
    detect_steps as detect_steps,
    fit_temperature_profile as fit_temperature_profile,
    periodogram_peak as periodogram_peak,
    slope_test as slope_test,
    temperature_regression as temperature_regression,
    trend_test as trend_test,
)

warn_moved("analysis.confirm", "analysis.reconcile.confirm")
