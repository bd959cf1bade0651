"""Moved to :mod:`analysis.fit.selection`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.fit.selection import (
    MAX_POINTS as MAX_POINTS,
    PER_OCTAVE as PER_OCTAVE,
    Selection as Selection,
    select_terms as select_terms,
    thin_by_octave as thin_by_octave,
)
from analysis.moved import warn_moved

warn_moved("analysis.fit_select", "analysis.fit.selection")
