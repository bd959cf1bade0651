"""Test sequences: the figures of repeated turn-ons and of temperature steps or ramps
(bias per turn-on, warm-up curve, repeatability, temperature sensitivity, hysteresis).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analysis.lazy import import_export

#: public name -> the module that defines it (imported on first use)
EXPORTS: dict[str, str] = {
    "CycleBias": "analysis.sequences.turn_on",
    "CycleSummary": "analysis.sequences.cycle_stats",
    "Repeatability": "analysis.sequences.turn_on",
    "TemperatureFit": "analysis.sequences.temperature_sensitivity",
    "WarmupCurve": "analysis.sequences.turn_on",
    "cycle_bias": "analysis.sequences.turn_on",
    "fit_temperature_sensitivity": "analysis.sequences.temperature_sensitivity",
    "hysteresis": "analysis.sequences.temperature_sensitivity",
    "summarize_cycles": "analysis.sequences.cycle_stats",
    "turn_on_repeatability": "analysis.sequences.turn_on",
    "warmup_curve": "analysis.sequences.turn_on",
}

__all__ = sorted(EXPORTS)

if TYPE_CHECKING:
    from analysis.sequences.cycle_stats import (
        CycleSummary as CycleSummary,
        summarize_cycles as summarize_cycles,
    )
    from analysis.sequences.temperature_sensitivity import (
        TemperatureFit as TemperatureFit,
        fit_temperature_sensitivity as fit_temperature_sensitivity,
        hysteresis as hysteresis,
    )
    from analysis.sequences.turn_on import (
        CycleBias as CycleBias,
        Repeatability as Repeatability,
        WarmupCurve as WarmupCurve,
        cycle_bias as cycle_bias,
        turn_on_repeatability as turn_on_repeatability,
        warmup_curve as warmup_curve,
    )


def __getattr__(name: str) -> object:
    """A public name, imported from its module on first use (PEP 562)."""
    return import_export(globals(), EXPORTS, name)
