"""Moved to :mod:`analysis.sequences.turn_on`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.moved import warn_moved
from analysis.sequences.turn_on import (
    BIAS_BATCHES as BIAS_BATCHES,
    CycleBias as CycleBias,
    Repeatability as Repeatability,
    WarmupCurve as WarmupCurve,
    cycle_bias as cycle_bias,
    sample_times_s as sample_times_s,
    sliding_means as sliding_means,
    turn_on_repeatability as turn_on_repeatability,
    warmup_curve as warmup_curve,
)

warn_moved("analysis.turn_on", "analysis.sequences.turn_on")
