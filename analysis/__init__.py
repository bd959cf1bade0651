"""Pure numerics of the gyro station: Allan variance, DAVAR, noise fits, simulation models.

Nothing here does I/O, prints, or keeps global state: numpy arrays and small frozen
dataclasses in, results out. The packages, each with one job (its ``__init__`` says which):

* ``analysis.units``: Units
* ``analysis.allan``: The Allan family of a rate record
* ``analysis.fit``: The five-term fit
* ``analysis.models``: Noise models and simulation
* ``analysis.gmwm``: The Haar wavelet variance and the GMWM
* ``analysis.davar``: The dynamic Allan variance (DAVAR) of a record
* ``analysis.sequences``: Test sequences
* ``analysis.figures``: Spec-sheet figures of a static run
* ``analysis.reconcile``: Model versus measurement

The main entry points are importable from here (``from analysis import allan_variance,
fit_noise_terms, gmwm_analysis, dynamic_allan_variance``); each is imported on first use, so
``import analysis`` stays cheap.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analysis.lazy import import_export

#: public name -> the module that defines it (imported on first use)
ENTRY_POINTS: dict[str, str] = {
    "allan_variance": "analysis.allan.variance",
    "overlapping_allan_variance": "analysis.allan.estimators",
    "cluster_allan_variance": "analysis.allan.estimators",
    "AllanResult": "analysis.allan.estimators",
    "deviation": "analysis.allan.deviations",
    "gap_allan_variance": "analysis.allan.gaps",
    "detect_spikes": "analysis.allan.outliers",
    "fit_noise_terms": "analysis.fit.least_squares",
    "NoiseCoefficients": "analysis.fit.result",
    "haar_wavelet_variance": "analysis.gmwm.wavelet",
    "gmwm_analysis": "analysis.gmwm.selection",
    "dynamic_allan_variance": "analysis.davar.estimators",
    "detect_warmup": "analysis.davar.warmup",
    "NoiseModel": "analysis.models.terms",
    "GyroSimulator": "analysis.models.simulation",
    "spec_figures": "analysis.figures.spec",
    "bias_stability": "analysis.figures.spec",
    "find_tones": "analysis.figures.tones",
    "reconcile_curve": "analysis.reconcile.loop",
}

__all__ = sorted(ENTRY_POINTS)

if TYPE_CHECKING:
    from analysis.allan.deviations import deviation as deviation
    from analysis.allan.estimators import (
        AllanResult as AllanResult,
        cluster_allan_variance as cluster_allan_variance,
        overlapping_allan_variance as overlapping_allan_variance,
    )
    from analysis.allan.gaps import gap_allan_variance as gap_allan_variance
    from analysis.allan.outliers import detect_spikes as detect_spikes
    from analysis.allan.variance import allan_variance as allan_variance
    from analysis.davar.estimators import dynamic_allan_variance as dynamic_allan_variance
    from analysis.davar.warmup import detect_warmup as detect_warmup
    from analysis.figures.spec import bias_stability as bias_stability, spec_figures as spec_figures
    from analysis.figures.tones import find_tones as find_tones
    from analysis.fit.least_squares import fit_noise_terms as fit_noise_terms
    from analysis.fit.result import NoiseCoefficients as NoiseCoefficients
    from analysis.gmwm.selection import gmwm_analysis as gmwm_analysis
    from analysis.gmwm.wavelet import haar_wavelet_variance as haar_wavelet_variance
    from analysis.models.simulation import GyroSimulator as GyroSimulator
    from analysis.models.terms import NoiseModel as NoiseModel
    from analysis.reconcile.loop import reconcile_curve as reconcile_curve


def __getattr__(name: str) -> object:
    """A public name, imported from its module on first use (PEP 562)."""
    return import_export(globals(), ENTRY_POINTS, name)
