"""Moved to :mod:`analysis.gmwm.models`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.gmwm.models import (
    KINDS as KINDS,
    MAX_TERMS as MAX_TERMS,
    REPEATABLE as REPEATABLE,
    RT_H as RT_H,
    Ar1Term as Ar1Term,
    Drift as Drift,
    Flicker as Flicker,
    FloatArray as FloatArray,
    GaussMarkovTerm as GaussMarkovTerm,
    GmwmModel as GmwmModel,
    GmwmModelError as GmwmModelError,
    QuantizationNoise as QuantizationNoise,
    RandomWalk as RandomWalk,
    TermKind as TermKind,
    WhiteNoise as WhiteNoise,
)
from analysis.moved import warn_moved

warn_moved("analysis.gmwm_models", "analysis.gmwm.models")
