"""Moved to :mod:`analysis.allan.curves`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.allan.curves import (
    FLICKER_AVAR_FACTOR as FLICKER_AVAR_FACTOR,
    as_tau as as_tau,
    deterministic_avar as deterministic_avar,
    gauss_markov_avar as gauss_markov_avar,
    sinusoid_avar as sinusoid_avar,
)
from analysis.moved import warn_moved

warn_moved("analysis.curves", "analysis.allan.curves")
