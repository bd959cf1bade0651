"""Spec-sheet figures of a static run: bias stability, the IEEE 952 read-offs, the tau
zones and tones the five-term model does not describe, the term sets a record cannot
tell apart, the accelerometer's figures, and the figures in other tools' conventions.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analysis.lazy import import_export

#: public name -> the module that defines it (imported on first use)
EXPORTS: dict[str, str] = {
    "AccelFigures": "analysis.figures.accel",
    "AxisNoise": "analysis.figures.tool_units",
    "BiasStability": "analysis.figures.spec",
    "CAUSE_THRESHOLD": "analysis.figures.spec",
    "MISFIT_THRESHOLD": "analysis.figures.spec",
    "REVIEW_CONFIDENCE": "analysis.figures.spec",
    "ReadOff": "analysis.figures.readoffs",
    "SpecFigures": "analysis.figures.spec",
    "Tone": "analysis.figures.tones",
    "accel_figures": "analysis.figures.accel",
    "arw_readoff": "analysis.figures.readoffs",
    "bias_instability_readoff": "analysis.figures.readoffs",
    "bias_stability": "analysis.figures.spec",
    "find_tones": "analysis.figures.tones",
    "fitted_arw_readoff_factor": "analysis.figures.spec",
    "resolve_ambiguity": "analysis.figures.ambiguity",
    "review_notes": "analysis.figures.spec",
    "spec_figures": "analysis.figures.spec",
}

__all__ = sorted(EXPORTS)

if TYPE_CHECKING:
    from analysis.figures.accel import AccelFigures as AccelFigures, accel_figures as accel_figures
    from analysis.figures.ambiguity import resolve_ambiguity as resolve_ambiguity
    from analysis.figures.readoffs import (
        ReadOff as ReadOff,
        arw_readoff as arw_readoff,
        bias_instability_readoff as bias_instability_readoff,
    )
    from analysis.figures.spec import (
        CAUSE_THRESHOLD as CAUSE_THRESHOLD,
        MISFIT_THRESHOLD as MISFIT_THRESHOLD,
        REVIEW_CONFIDENCE as REVIEW_CONFIDENCE,
        BiasStability as BiasStability,
        SpecFigures as SpecFigures,
        bias_stability as bias_stability,
        fitted_arw_readoff_factor as fitted_arw_readoff_factor,
        review_notes as review_notes,
        spec_figures as spec_figures,
    )
    from analysis.figures.tones import Tone as Tone, find_tones as find_tones
    from analysis.figures.tool_units import AxisNoise as AxisNoise


def __getattr__(name: str) -> object:
    """A public name, imported from its module on first use (PEP 562)."""
    return import_export(globals(), EXPORTS, name)
