"""Noise models and simulation: the noise terms and their theoretical Allan variance,
the seeded generators and streaming simulators (gyro and accelerometer), the FOG model
and the power-cycle model simulated units follow.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analysis.lazy import import_export

#: public name -> the module that defines it (imported on first use)
EXPORTS: dict[str, str] = {
    "AccelNoiseModel": "analysis.models.accel_noise",
    "AccelSimulator": "analysis.models.accel_noise",
    "AngleRandomWalk": "analysis.models.terms",
    "Bias": "analysis.models.terms",
    "BiasInstability": "analysis.models.terms",
    "BiasSteps": "analysis.models.terms",
    "FogParameters": "analysis.models.fog",
    "GaussMarkov": "analysis.models.terms",
    "GyroSimulator": "analysis.models.simulation",
    "NoiseModel": "analysis.models.terms",
    "NoiseTerm": "analysis.models.terms",
    "PowerCycleModel": "analysis.models.power_cycle",
    "Quantization": "analysis.models.terms",
    "RateRamp": "analysis.models.terms",
    "RateRandomWalk": "analysis.models.terms",
    "SimulatedChunk": "analysis.models.simulation",
    "Sinusoid": "analysis.models.terms",
    "TERM_NAMES": "analysis.models.terms",
    "TERM_TYPES": "analysis.models.terms",
    "TemperatureBias": "analysis.models.terms",
    "fog_from_indicators": "analysis.models.fog",
    "simulate": "analysis.models.simulation",
    "term_type": "analysis.models.terms",
}

__all__ = sorted(EXPORTS)

if TYPE_CHECKING:
    from analysis.models.accel_noise import (
        AccelNoiseModel as AccelNoiseModel,
        AccelSimulator as AccelSimulator,
    )
    from analysis.models.fog import (
        FogParameters as FogParameters,
        fog_from_indicators as fog_from_indicators,
    )
    from analysis.models.power_cycle import PowerCycleModel as PowerCycleModel
    from analysis.models.simulation import (
        GyroSimulator as GyroSimulator,
        SimulatedChunk as SimulatedChunk,
        simulate as simulate,
    )
    from analysis.models.terms import (
        TERM_NAMES as TERM_NAMES,
        TERM_TYPES as TERM_TYPES,
        AngleRandomWalk as AngleRandomWalk,
        Bias as Bias,
        BiasInstability as BiasInstability,
        BiasSteps as BiasSteps,
        GaussMarkov as GaussMarkov,
        NoiseModel as NoiseModel,
        NoiseTerm as NoiseTerm,
        Quantization as Quantization,
        RateRamp as RateRamp,
        RateRandomWalk as RateRandomWalk,
        Sinusoid as Sinusoid,
        TemperatureBias as TemperatureBias,
        term_type as term_type,
    )


def __getattr__(name: str) -> object:
    """A public name, imported from its module on first use (PEP 562)."""
    return import_export(globals(), EXPORTS, name)
