"""Moved to :mod:`analysis.allan.kernels_numba`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.allan.kernels_numba import (
    oadev_one as oadev_one,
    oadev_stretch_sums as oadev_stretch_sums,
    oadev_sums as oadev_sums,
    span_sum as span_sum,
    window_sums as window_sums,
    window_sums_segments as window_sums_segments,
)
from analysis.moved import warn_moved

warn_moved("analysis.kernels_numba", "analysis.allan.kernels_numba")
