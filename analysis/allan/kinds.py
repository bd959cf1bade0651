"""The names of the Allan family's deviations, estimators and tau grids, without the
numerics: what a command's parser offers (``station analyze --help`` imports this, not
the estimators)."""

from __future__ import annotations

from typing import Literal

DeviationKind = Literal["oadev", "adev", "mdev", "hdev", "ohdev", "tdev", "totdev", "theo1"]
#: Every deviation :func:`analysis.allan.deviations.deviation` computes, the overlapping
#: Allan deviation first.
DEVIATION_KINDS: tuple[DeviationKind, ...] = (
    "oadev",
    "adev",
    "mdev",
    "hdev",
    "ohdev",
    "tdev",
    "totdev",
    "theo1",
)
#: The Allan variance estimators: fully overlapping, or non-overlapping clusters.
Estimator = Literal["overlapping", "clusters"]
