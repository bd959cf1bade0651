"""Moved to :mod:`analysis.gmwm.result`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.gmwm.result import (
    GmwmFit as GmwmFit,
)
from analysis.moved import warn_moved

warn_moved("analysis.gmwm_fit", "analysis.gmwm.result")
