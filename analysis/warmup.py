"""Moved to :mod:`analysis.davar.warmup`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.davar.warmup import (
    WarmupVerdict as WarmupVerdict,
    detect_warmup as detect_warmup,
)
from analysis.moved import warn_moved

warn_moved("analysis.warmup", "analysis.davar.warmup")
