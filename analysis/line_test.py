"""Moved to :mod:`analysis.reconcile.line_test`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.moved import warn_moved
from analysis.reconcile.line_test import (
    LINE_ALPHA as LINE_ALPHA,
    MEDIAN_VARIANCE as MEDIAN_VARIANCE,
    OVERSAMPLE as OVERSAMPLE,
    LineDetection as LineDetection,
    strongest_line as strongest_line,
)

warn_moved("analysis.line_test", "analysis.reconcile.line_test")
