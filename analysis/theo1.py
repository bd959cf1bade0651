"""Moved to :mod:`analysis.allan.theo1`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.allan.theo1 import (
    DIRECT_TERMS as DIRECT_TERMS,
    DIRECT_TERMS_MAX as DIRECT_TERMS_MAX,
    TARGET_RELATIVE_ERROR as TARGET_RELATIVE_ERROR,
    theo1_sum_direct as theo1_sum_direct,
    theo1_sum_fast as theo1_sum_fast,
    theo1_sums as theo1_sums,
)
from analysis.moved import warn_moved

warn_moved("analysis.theo1", "analysis.allan.theo1")
