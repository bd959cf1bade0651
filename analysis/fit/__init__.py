"""The five-term fit: the IEEE noise terms fitted to an Allan curve (ols, wls, logwls,
constrained), the model they share, which terms the data resolve, and their standard
errors.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analysis.lazy import import_export

#: public name -> the module that defines it (imported on first use)
EXPORTS: dict[str, str] = {
    "Alternative": "analysis.fit.least_squares",
    "BETA_FACTOR": "analysis.fit.least_squares",
    "COEFFICIENT_NAMES": "analysis.fit.least_squares",
    "DEFAULT_MODEL_ERROR": "analysis.fit.least_squares",
    "FIT_METHODS": "analysis.fit.least_squares",
    "FitMethod": "analysis.fit.least_squares",
    "NOTED_MISFIT": "analysis.fit.least_squares",
    "NoiseCoefficients": "analysis.fit.least_squares",
    "OLS40_MAX_ERROR": "analysis.fit.least_squares",
    "Reference": "analysis.fit.least_squares",
    "TAU_POWER": "analysis.fit.least_squares",
    "TERMS": "analysis.fit.least_squares",
    "TO_DATASHEET": "analysis.fit.least_squares",
    "check_terms": "analysis.fit.least_squares",
    "design_matrix": "analysis.fit.least_squares",
    "fit_every_method": "analysis.fit.least_squares",
    "fit_noise_terms": "analysis.fit.least_squares",
    "fit_term_set": "analysis.fit.least_squares",
    "log_tau_share": "analysis.fit.least_squares",
    "select_terms": "analysis.fit.selection",
    "theoretical_avar": "analysis.fit.least_squares",
}

__all__ = sorted(EXPORTS)

if TYPE_CHECKING:
    from analysis.fit.least_squares import (
        BETA_FACTOR as BETA_FACTOR,
        COEFFICIENT_NAMES as COEFFICIENT_NAMES,
        DEFAULT_MODEL_ERROR as DEFAULT_MODEL_ERROR,
        FIT_METHODS as FIT_METHODS,
        NOTED_MISFIT as NOTED_MISFIT,
        OLS40_MAX_ERROR as OLS40_MAX_ERROR,
        TAU_POWER as TAU_POWER,
        TERMS as TERMS,
        TO_DATASHEET as TO_DATASHEET,
        Alternative as Alternative,
        FitMethod as FitMethod,
        NoiseCoefficients as NoiseCoefficients,
        Reference as Reference,
        check_terms as check_terms,
        design_matrix as design_matrix,
        fit_every_method as fit_every_method,
        fit_noise_terms as fit_noise_terms,
        fit_term_set as fit_term_set,
        log_tau_share as log_tau_share,
        theoretical_avar as theoretical_avar,
    )
    from analysis.fit.selection import select_terms as select_terms


def __getattr__(name: str) -> object:
    """A public name, imported from its module on first use (PEP 562)."""
    return import_export(globals(), EXPORTS, name)
