"""The Haar wavelet variance and the GMWM: noise models fitted to the wavelet variance,
their weights, and the selection of a model by the wavelet information criterion.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analysis.lazy import import_export

#: public name -> the module that defines it (imported on first use)
EXPORTS: dict[str, str] = {
    "ALLAN_TERM": "analysis.gmwm.estimator",
    "GMWM_MIN_BLOCKS": "analysis.gmwm.estimator",
    "GRID_OCTAVES_BELOW_SAMPLE": "analysis.gmwm.estimator",
    "GRID_PER_OCTAVE": "analysis.gmwm.estimator",
    "GmwmFit": "analysis.gmwm.estimator",
    "GmwmModel": "analysis.gmwm.models",
    "GmwmSelection": "analysis.gmwm.selection",
    "MAX_CONDITION": "analysis.gmwm.estimator",
    "REFINED_STARTS": "analysis.gmwm.estimator",
    "REJECT_P": "analysis.gmwm.estimator",
    "SHORTEST_T_SAMPLES": "analysis.gmwm.estimator",
    "START_SEPARATION": "analysis.gmwm.estimator",
    "WaveletVariance": "analysis.gmwm.wavelet",
    "check_model_scales": "analysis.gmwm.estimator",
    "gmwm": "analysis.gmwm.estimator",
    "gmwm_analysis": "analysis.gmwm.selection",
    "gmwm_levels": "analysis.gmwm.estimator",
    "gmwm_with_covariance": "analysis.gmwm.estimator",
    "haar_wavelet_variance": "analysis.gmwm.wavelet",
    "select_model": "analysis.gmwm.selection",
    "weight_covariance": "analysis.gmwm.estimator",
}

__all__ = sorted(EXPORTS)

if TYPE_CHECKING:
    from analysis.gmwm.estimator import (
        ALLAN_TERM as ALLAN_TERM,
        GMWM_MIN_BLOCKS as GMWM_MIN_BLOCKS,
        GRID_OCTAVES_BELOW_SAMPLE as GRID_OCTAVES_BELOW_SAMPLE,
        GRID_PER_OCTAVE as GRID_PER_OCTAVE,
        MAX_CONDITION as MAX_CONDITION,
        REFINED_STARTS as REFINED_STARTS,
        REJECT_P as REJECT_P,
        SHORTEST_T_SAMPLES as SHORTEST_T_SAMPLES,
        START_SEPARATION as START_SEPARATION,
        GmwmFit as GmwmFit,
        check_model_scales as check_model_scales,
        gmwm as gmwm,
        gmwm_levels as gmwm_levels,
        gmwm_with_covariance as gmwm_with_covariance,
        weight_covariance as weight_covariance,
    )
    from analysis.gmwm.models import GmwmModel as GmwmModel
    from analysis.gmwm.selection import (
        GmwmSelection as GmwmSelection,
        gmwm_analysis as gmwm_analysis,
        select_model as select_model,
    )
    from analysis.gmwm.wavelet import (
        WaveletVariance as WaveletVariance,
        haar_wavelet_variance as haar_wavelet_variance,
    )


def __getattr__(name: str) -> object:
    """A public name, imported from its module on first use (PEP 562)."""
    return import_export(globals(), EXPORTS, name)
