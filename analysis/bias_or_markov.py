"""Moved to :mod:`analysis.figures.bias_or_markov`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.figures.bias_or_markov import (
    GMWM_TERM as GMWM_TERM,
    MARKOV_LOOKALIKES as MARKOV_LOOKALIKES,
    gmwm_model as gmwm_model,
    markov_alternative as markov_alternative,
)
from analysis.moved import warn_moved

warn_moved("analysis.bias_or_markov", "analysis.figures.bias_or_markov")
