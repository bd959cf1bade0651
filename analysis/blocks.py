"""Moved to :mod:`analysis.allan.blocks`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.allan.blocks import (
    BLOCK_SAMPLES as BLOCK_SAMPLES,
    LONG_SAMPLES as LONG_SAMPLES,
    any_where as any_where,
    column_sums as column_sums,
    decimated as decimated,
    finite_batch_means as finite_batch_means,
    first_non_finite as first_non_finite,
    group_means as group_means,
    is_long as is_long,
    is_mapped as is_mapped,
    median as median,
    nan_mean as nan_mean,
    order_statistic as order_statistic,
    pairwise_sum as pairwise_sum,
    release as release,
    spans as spans,
)
from analysis.moved import warn_moved

warn_moved("analysis.blocks", "analysis.allan.blocks")
