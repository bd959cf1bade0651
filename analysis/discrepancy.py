"""Moved to :mod:`analysis.reconcile.discrepancy`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.moved import warn_moved
from analysis.reconcile.discrepancy import (
    BAND_LEVEL as BAND_LEVEL,
    BATCH_SAMPLES as BATCH_SAMPLES,
    MODEL_FLOOR as MODEL_FLOOR,
    TERM_CACHE_VALUES as TERM_CACHE_VALUES,
    Comparison as Comparison,
    ComparisonCache as ComparisonCache,
    GapNull as GapNull,
    LogPrecision as LogPrecision,
    MeasuredCurve as MeasuredCurve,
    MonteCarloBand as MonteCarloBand,
    allan_on_grid as allan_on_grid,
    block_means as block_means,
    compare as compare,
    gap_statistic as gap_statistic,
    log_precision as log_precision,
    measure_curve as measure_curve,
    monte_carlo_band as monte_carlo_band,
    ranges_outside as ranges_outside,
    reconcile_grid as reconcile_grid,
    regression_slopes as regression_slopes,
    standardized_log_ratio as standardized_log_ratio,
)

warn_moved("analysis.discrepancy", "analysis.reconcile.discrepancy")
