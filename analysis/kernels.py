"""Moved to :mod:`analysis.allan.kernels`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.allan.kernels import (
    COMPILED_MIN_TERMS as COMPILED_MIN_TERMS,
    COMPILED_MIN_WINDOW_TERMS as COMPILED_MIN_WINDOW_TERMS,
    Backend as Backend,
    have_compiled as have_compiled,
    overlapping_stretch_sums as overlapping_stretch_sums,
    overlapping_sums as overlapping_sums,
    overlapping_sums_reference as overlapping_sums_reference,
    second_difference_squares as second_difference_squares,
    window_sums as window_sums,
)
from analysis.moved import warn_moved

warn_moved("analysis.kernels", "analysis.allan.kernels")
