"""Moved to :mod:`analysis.fit.log`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.fit.log import (
    MAX_STEPS as MAX_STEPS,
    LogData as LogData,
    fit_log as fit_log,
    log_data as log_data,
    log_tau_share as log_tau_share,
)
from analysis.moved import warn_moved

warn_moved("analysis.fit_log", "analysis.fit.log")
