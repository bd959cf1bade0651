"""Moved to :mod:`analysis.figures.tones`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.figures.tones import (
    ALPHA as ALPHA,
    HANN_OVERLAP_RHO as HANN_OVERLAP_RHO,
    MAX_SEGMENT as MAX_SEGMENT,
    MAX_TONES as MAX_TONES,
    MIN_HALF_WINDOW as MIN_HALF_WINDOW,
    MIN_PEAK_RATIO as MIN_PEAK_RATIO,
    MIN_SEGMENT as MIN_SEGMENT,
    MIN_SEGMENTS as MIN_SEGMENTS,
    WINDOW_FRACTION as WINDOW_FRACTION,
    Tone as Tone,
    find_tones as find_tones,
    running_background as running_background,
    tones_avar as tones_avar,
    welch_edf as welch_edf,
    welch_segment as welch_segment,
    welch_spectrum as welch_spectrum,
)
from analysis.moved import warn_moved

warn_moved("analysis.tones", "analysis.figures.tones")
