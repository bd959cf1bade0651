"""Moved to :mod:`analysis.allan.outliers`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.allan.outliers import (
    FALSE_ALARM as FALSE_ALARM,
    HALF_WINDOW as HALF_WINDOW,
    MAD_TO_SIGMA as MAD_TO_SIGMA,
    MAX_REMOVED_SHARE as MAX_REMOVED_SHARE,
    MAX_SPIKE_SAMPLES as MAX_SPIKE_SAMPLES,
    SCALE_SAMPLES as SCALE_SAMPLES,
    Spike as Spike,
    SpikeDetection as SpikeDetection,
    detect_spikes as detect_spikes,
    min_samples as min_samples,
    neighbour_residuals as neighbour_residuals,
    replace_flagged as replace_flagged,
    replace_spikes as replace_spikes,
    resolution as resolution,
    spike_threshold as spike_threshold,
)
from analysis.moved import warn_moved

warn_moved("analysis.outliers", "analysis.allan.outliers")
