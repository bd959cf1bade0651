"""Moved to :mod:`analysis.gmwm.wavelet`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.gmwm.wavelet import (
    CI_METHODS as CI_METHODS,
    LAG_BLOCK as LAG_BLOCK,
    LAG_PRODUCTS as LAG_PRODUCTS,
    LAG_THIN as LAG_THIN,
    LAG_WIDTHS as LAG_WIDTHS,
    MIN_BLOCKS as MIN_BLOCKS,
    ROBUST_EFFICIENCY as ROBUST_EFFICIENCY,
    ROBUST_MAX_ITER as ROBUST_MAX_ITER,
    CiMethod as CiMethod,
    WaveletVariance as WaveletVariance,
    dyadic_m as dyadic_m,
    haar_coefficients as haar_coefficients,
    haar_wavelet_variance as haar_wavelet_variance,
    huber_constant as huber_constant,
    huber_delta as huber_delta,
    huber_efficiency as huber_efficiency,
    robust_scale2 as robust_scale2,
)
from analysis.moved import warn_moved

warn_moved("analysis.wavelet", "analysis.gmwm.wavelet")
