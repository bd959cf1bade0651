"""The Allan family of a rate record: the estimators and their tau grids, the other
deviations (modified, Hadamard, time, total, Theo1), confidence intervals and noise
identification, records with gaps or spikes, and the kernels and block walks beneath
them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from analysis.lazy import import_export

#: public name -> the module that defines it (imported on first use)
EXPORTS: dict[str, str] = {
    "AllanDeviationMixin": "analysis.allan.estimators",
    "AllanResult": "analysis.allan.estimators",
    "DeviationResult": "analysis.allan.deviations",
    "Estimator": "analysis.allan.estimators",
    "GapSummary": "analysis.allan.gaps",
    "InputKind": "analysis.allan.estimators",
    "LOG_GRID_MIN_CLUSTERS": "analysis.allan.estimators",
    "Missing": "analysis.allan.estimators",
    "NoiseIdentification": "analysis.allan.noise_id",
    "ONE_SIGMA": "analysis.allan.estimators",
    "SpikeDetection": "analysis.allan.outliers",
    "TauGrid": "analysis.allan.estimators",
    "all_m": "analysis.allan.estimators",
    "allan_edf": "analysis.allan.confidence",
    "allan_edf_grid": "analysis.allan.estimators",
    "allan_variance": "analysis.allan.variance",
    "analysis_log_m": "analysis.allan.estimators",
    "as_samples": "analysis.allan.estimators",
    "check_sample_rate": "analysis.allan.estimators",
    "chi2_interval": "analysis.allan.estimators",
    "cluster_allan_variance": "analysis.allan.estimators",
    "cluster_sums": "analysis.allan.estimators",
    "cumulative_angle": "analysis.allan.estimators",
    "detect_spikes": "analysis.allan.outliers",
    "deviation": "analysis.allan.deviations",
    "estimator_terms": "analysis.allan.estimators",
    "gap_allan_variance": "analysis.allan.gaps",
    "gap_summary": "analysis.allan.gaps",
    "identify_noise": "analysis.allan.noise_id",
    "local_noise_alpha": "analysis.allan.estimators",
    "log_m": "analysis.allan.estimators",
    "m_from_tau": "analysis.allan.estimators",
    "octave_m": "analysis.allan.estimators",
    "overlapping_allan_variance": "analysis.allan.estimators",
    "overlapping_edf": "analysis.allan.estimators",
    "overlapping_sums": "analysis.allan.estimators",
    "partial_allan_variance": "analysis.allan.partial_clusters",
    "replace_spikes": "analysis.allan.outliers",
    "resolve_m": "analysis.allan.estimators",
}

__all__ = sorted(EXPORTS)

if TYPE_CHECKING:
    from analysis.allan.confidence import allan_edf as allan_edf
    from analysis.allan.deviations import DeviationResult as DeviationResult, deviation as deviation
    from analysis.allan.estimators import (
        LOG_GRID_MIN_CLUSTERS as LOG_GRID_MIN_CLUSTERS,
        ONE_SIGMA as ONE_SIGMA,
        AllanDeviationMixin as AllanDeviationMixin,
        AllanResult as AllanResult,
        Estimator as Estimator,
        InputKind as InputKind,
        Missing as Missing,
        TauGrid as TauGrid,
        all_m as all_m,
        allan_edf_grid as allan_edf_grid,
        analysis_log_m as analysis_log_m,
        as_samples as as_samples,
        check_sample_rate as check_sample_rate,
        chi2_interval as chi2_interval,
        cluster_allan_variance as cluster_allan_variance,
        cluster_sums as cluster_sums,
        cumulative_angle as cumulative_angle,
        estimator_terms as estimator_terms,
        local_noise_alpha as local_noise_alpha,
        log_m as log_m,
        m_from_tau as m_from_tau,
        octave_m as octave_m,
        overlapping_allan_variance as overlapping_allan_variance,
        overlapping_edf as overlapping_edf,
        overlapping_sums as overlapping_sums,
        resolve_m as resolve_m,
    )
    from analysis.allan.gaps import (
        GapSummary as GapSummary,
        gap_allan_variance as gap_allan_variance,
        gap_summary as gap_summary,
    )
    from analysis.allan.noise_id import (
        NoiseIdentification as NoiseIdentification,
        identify_noise as identify_noise,
    )
    from analysis.allan.outliers import (
        SpikeDetection as SpikeDetection,
        detect_spikes as detect_spikes,
        replace_spikes as replace_spikes,
    )
    from analysis.allan.partial_clusters import partial_allan_variance as partial_allan_variance
    from analysis.allan.variance import allan_variance as allan_variance


def __getattr__(name: str) -> object:
    """A public name, imported from its module on first use (PEP 562)."""
    return import_export(globals(), EXPORTS, name)
