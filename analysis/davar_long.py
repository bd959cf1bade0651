"""Moved to :mod:`analysis.davar.long`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.davar.long import (
    dynamic_allan_variance_long as dynamic_allan_variance_long,
    group_span as group_span,
)
from analysis.moved import warn_moved

warn_moved("analysis.davar_long", "analysis.davar.long")
