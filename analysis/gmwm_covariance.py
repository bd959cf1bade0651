"""Moved to :mod:`analysis.gmwm.covariance`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.gmwm.covariance import (
    DIRECT_LAGS as DIRECT_LAGS,
    FIRST_PIECE as FIRST_PIECE,
    GL_POINTS as GL_POINTS,
    INSIDE as INSIDE,
    TAIL_CORRELATION_TIMES as TAIL_CORRELATION_TIMES,
    TAIL_WINDOWS_FLICKER as TAIL_WINDOWS_FLICKER,
    wv_covariance as wv_covariance,
)
from analysis.moved import warn_moved

warn_moved("analysis.gmwm_covariance", "analysis.gmwm.covariance")
