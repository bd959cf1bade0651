"""The Allan variance by name: the estimator, and how missing samples are read.

:func:`allan_variance` dispatches to the gap-free estimators of
:mod:`analysis.allan.estimators` or, with ``missing="gap"``, to the gap estimator of
:mod:`analysis.allan.gaps` (which builds on the estimators: this module sits above
both).
"""

from __future__ import annotations

from numpy.typing import ArrayLike

from analysis.allan.confidence import ONE_SIGMA
from analysis.allan.estimators import (
    AllanResult,
    Estimator,
    InputKind,
    Missing,
    TauGrid,
    cluster_allan_variance,
    overlapping_allan_variance,
)
from analysis.allan.gaps import gap_allan_variance


def allan_variance(
    samples: ArrayLike,
    sample_rate_hz: float,
    *,
    estimator: Estimator = "overlapping",
    taus: TauGrid | ArrayLike = "log",
    input_kind: InputKind = "rate",
    confidence: float = ONE_SIGMA,
    missing: Missing = "raise",
) -> AllanResult:
    """Allan variance with the named estimator (``"overlapping"`` or ``"clusters"``).

    ``missing="gap"`` reads NaN samples as missing ones on the record's time grid: no
    difference straddles them (:func:`analysis.allan.gaps.gap_allan_variance`); the default
    refuses them (:class:`NonFiniteSamplesError`).
    """
    if missing == "gap":
        return gap_allan_variance(samples, sample_rate_hz, estimator=estimator, taus=taus,
                                  input_kind=input_kind, confidence=confidence)
    if missing != "raise":
        raise ValueError(f"missing must be 'raise' or 'gap', got {missing!r}")
    if estimator == "overlapping":
        return overlapping_allan_variance(samples, sample_rate_hz, taus=taus,
                                          input_kind=input_kind, confidence=confidence)
    if estimator == "clusters":
        return cluster_allan_variance(samples, sample_rate_hz, taus=taus, input_kind=input_kind,
                                      confidence=confidence)
    raise ValueError(f"estimator must be 'overlapping' or 'clusters', got {estimator!r}")
