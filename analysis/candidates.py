"""Moved to :mod:`analysis.reconcile.candidates`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.moved import warn_moved
from analysis.reconcile.candidates import (
    ADD_DEFAULTS as ADD_DEFAULTS,
    BIC_THRESHOLD as BIC_THRESHOLD,
    MIN_CYCLES as MIN_CYCLES,
    NYQUIST_PERIODS as NYQUIST_PERIODS,
    SCALE_GRID as SCALE_GRID,
    SCALE_KEYS as SCALE_KEYS,
    SHAPE_KEYS as SHAPE_KEYS,
    SHAPE_POINTS_PER_OCTAVE as SHAPE_POINTS_PER_OCTAVE,
    CandidateFit as CandidateFit,
    candidate_names as candidate_names,
    change_of as change_of,
    fit_candidate as fit_candidate,
    fit_candidates as fit_candidates,
    tau_range as tau_range,
)

warn_moved("analysis.candidates", "analysis.reconcile.candidates")
