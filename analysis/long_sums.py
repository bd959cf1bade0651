"""Moved to :mod:`analysis.allan.long_sums`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.allan.long_sums import (
    box_square_sum as box_square_sum,
    cluster_square_sums as cluster_square_sums,
    hadamard_square_sum as hadamard_square_sum,
    running_sums as running_sums,
    second_differences as second_differences,
    total_square_sum as total_square_sum,
)
from analysis.moved import warn_moved

warn_moved("analysis.long_sums", "analysis.allan.long_sums")
